"""The play and gear operators start engaged in the direction of the record's first motion (issue 7, session 58).

Until session 58 they started centred in their gap at the first kept sample. A record whose first kept
sample is mid-motion (the filter's border is trimmed) then had no friction for the first half-gap of
travel in every backlash and gear-spring model, while the baseline's Coulomb column had the full level:
on independent record 25204 (its own two-mass integrator; a gap of 1.3× the gear's wind-up) one such
sample misfitted by 4.8 N·m made the true gap lose its held-out test by −31 %. The baseline's own
convention (``fit.stick_ramp``: a rest at the start takes the sliding value after it) is now the
operators' (docs/calibration.md, "Session 58, second change";
``data/calibration_benchmark/session58_play_start/``).
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from plant.calibration import fit
from plant.calibration.bench_records import make_record
from plant.calibration.io import load_record


@pytest.mark.parametrize("direction", [1.0, -1.0])
def test_an_engaged_play_moves_with_the_input_from_the_first_sample(direction):
    q = direction * np.linspace(0.0, 1e-3, 50)
    ql = fit.play_operator(q, 2e-4, direction)
    assert ql[0] == pytest.approx(q[0] - direction * 1e-4)
    assert np.allclose(np.diff(ql), np.diff(q))                     # no dead travel at the start
    centred = fit.play_operator(q, 2e-4)
    assert np.allclose(centred[:4], 0.0)                            # the old start: 1e-4 of dead travel


def test_an_engaged_gear_transmits_the_full_friction_at_the_first_sample():
    q = np.linspace(0.0, 1e-3, 50)
    _, c = fit.geared_coulomb(q, 1e-4, 5e-5, 1.0)
    assert c[0] == pytest.approx(1.0) and np.all(c == pytest.approx(1.0))
    _, c0 = fit.geared_coulomb(q, 1e-4, 5e-5)
    assert c0[0] == 0.0


def test_the_start_state_is_the_baselines(tmp_path):
    """``first_direction`` is the sign of the baseline's Coulomb column at the first sample."""
    rec = make_record(25204)
    rec.write_csv(tmp_path / "r.csv")
    prep = fit.prepare(load_record(tmp_path / "r.csv"))
    assert fit.first_direction(prep, prep.dq) == np.sign(prep.coulomb[0]) == 1.0
    assert fit.first_direction(prep, -prep.dq.copy()) == -1.0        # any other velocity: its first sign


def test_independent_25204_a_true_gap_no_longer_misfits_the_first_sample(monkeypatch, tmp_path):
    """With the true gap and stiffness in the model, the first kept sample fits as the baseline's does
    (before: 4.8 N·m against 0.2). With the operators patched back to the centred start the misfit
    returns, so the check can fail."""
    rec = make_record(25204)
    assert rec.hidden == ("backlash",)
    rec.write_csv(tmp_path / "r.csv")
    prep = fit.prepare(load_record(tmp_path / "r.csv"))
    k, gap, fc = rec.meta["two_mass"]["stiffness_nm_rad"], rec.truth["backlash"]["width_rad"], rec.meta["fc"]
    spec = dataclasses.replace(fit.ModelSpec(), gear_stiffness=k, spring_coulomb=fc, backlash_width=gap)
    base = fit.fit_model(prep, fit.ModelSpec(), refine=False)
    geared = fit.fit_model(prep, spec, refine=False)
    assert abs(geared.residual[0]) < 2 * abs(base.residual[0]) + 0.5
    monkeypatch.setattr(fit, "first_direction", lambda prep, dq: 0.0)
    old = fit.fit_model(prep, spec, refine=False)
    assert abs(old.residual[0]) > 5 * abs(base.residual[0]) + 1.0
