"""A library term that is a slice of an out-of-library description is refused (issue 7, session 59).

Library first: a friction drift or a delay description is named (in ``unexplained``) only if it predicts
significantly better than the best library candidate, so a library term could be named on a consistent
slice of the same structure. ``loop._beats_out_of_library`` fits the two against each other on the same
held-out blocks: the candidate is refused where, beside a description that predicts more, it no longer
predicts while the description still does beside it. These tests give the rule held-out errors chosen in
the test (the both-model's errors in place of a fit), so each branch is checked on values the loop did not
produce; the decision on never-used records is in ``data/calibration_benchmark/session59_out_of_library/``
and docs/calibration.md, "Session 59".
"""
from __future__ import annotations

import numpy as np
from fit_stubs import BASE, stub_fit

from plant.calibration import loop

N = 2000          # held-out samples: 40 rank-test batches of 50
ZC = 3.6          # the run's level for 12 candidates × 5 steps


def errors(values) -> loop.CVErrors:
    """Held-out errors as the loop's ``cv_losses`` returns them (no row extrapolated)."""
    e = np.asarray(values, float).view(loop.CVErrors)
    e.extrapolated = np.zeros(e.size, dtype=bool)
    return e


def noise(seed: int, scale: float) -> np.ndarray:
    return scale * np.random.default_rng(seed).standard_normal(N)


def candidates(c_loss, o_loss, c_gain=10.0, o_gain=30.0, o_kind="delay"):
    c = {"kind": "asymmetric_friction", "group": "velocity", "fit": stub_fit(BASE, [1.0, 2.0, 3.0, 0.0]),
         "loss": errors(c_loss), "cv_gain_pct": c_gain, "cv_z": 4.5}
    o = {"kind": o_kind, "group": "out-of-library", "fit": stub_fit(BASE, [1.0, 2.0, 3.0, 0.0]),
         "loss": errors(o_loss), "cv_gain_pct": o_gain, "cv_z": 3.0}
    return c, [c, o]


def run(monkeypatch, c, cands, both_loss):
    specs = []

    def fake_cv_losses(prep, spec, k_folds=8):
        specs.append(spec)
        return errors(both_loss)

    monkeypatch.setattr(loop, "cv_losses", fake_cv_losses)
    return loop._beats_out_of_library(None, c, cands, ZC, loop.LoopConfig()), specs


def test_a_candidate_that_the_description_holds_is_refused_with_both_figures(monkeypatch):
    # the description explains everything the candidate does and more: beside it the candidate adds nothing,
    # while beside the candidate the description still takes a large share in every batch
    e = noise(1, 1.0)
    c, cands = candidates(c_loss=1.5 * e, o_loss=e)
    why, specs = run(monkeypatch, c, cands, both_loss=e)
    assert why is not None and "delay between the torque and the motion" in why and "no longer predicts" in why, why
    assert "still predicts beside the candidate" in why
    # the model with both is the candidate's own with the description added
    assert specs and "delay" in specs[0].nuisance


def test_two_terms_that_neither_hold_beside_the_other_leave_the_library_kind(monkeypatch):
    # one structure, two descriptions (used independent 24110: a real asymmetric friction whose drift
    # description predicted as much): beside each other neither predicts more, so library first stands
    e = noise(2, 1.0)
    c, cands = candidates(c_loss=e, o_loss=e)
    why, _ = run(monkeypatch, c, cands, both_loss=e)
    assert why is None


def test_a_candidate_that_keeps_its_gain_beside_the_description_is_kept(monkeypatch):
    e = noise(3, 1.0)
    c, cands = candidates(c_loss=1.2 * e, o_loss=1.2 * e)
    why, _ = run(monkeypatch, c, cands, both_loss=0.8 * e)
    assert why is None
    assert c["beside_out_of_library"]["delay"]["candidate"][1] >= ZC


def test_a_description_that_predicts_less_than_the_candidate_is_not_asked(monkeypatch):
    e = noise(4, 1.0)
    c, cands = candidates(c_loss=e, o_loss=e, c_gain=30.0, o_gain=10.0)
    why, specs = run(monkeypatch, c, cands, both_loss=e)
    assert why is None and not specs


def test_a_drift_goes_into_the_model_with_the_shape_chosen_for_it(monkeypatch):
    e = noise(5, 1.0)
    c, cands = candidates(c_loss=1.5 * e, o_loss=e, o_kind="friction_drift")
    cands[1]["fit"].spec.nuisance.append("friction_drift")
    cands[1]["fit"].spec.drift_time_constant, cands[1]["fit"].spec.drift_heating = 0.25, True
    why, specs = run(monkeypatch, c, cands, both_loss=e)
    assert why is not None and "friction drift" in why
    assert specs[0].nuisance == ["friction_drift"] and specs[0].drift_time_constant == 0.25 and specs[0].drift_heating
