"""Asymmetric friction goes through the phase guard (issue 7; docs/calibration.md, "Session 32").

The asymmetric model is its twin plus the column ``|w|`` and nothing else
(``tests/test_calibration_asymmetry_twin.py``). On a periodic motion ``|w|`` is a function of the
motion's phase, as gravity's ``sin θ`` and the reversal states are, so it can stand in for an error
of the model along that phase. Found on blind seed 542 (the blind generator, written without reading
the loop: ``plant/calibration/blind_records.py``): a gravity imbalance on a sinusoid, which the guard
refuses, was named ``asymmetric_friction`` instead, with a 5:1 split of the Coulomb level.

The second test is a record written here from the equations, open loop, with a real direction-
dependent viscous friction on a sinusoid: the guard must not take it.
"""

from __future__ import annotations

import math

import numpy as np

from plant.calibration import blind_records as blind
from plant.calibration import loop
from plant.calibration.fit import prepare
from plant.calibration.io import load_record


def test_blind_542_gravity_on_a_sinusoid_is_not_named_asymmetric_friction(tmp_path, monkeypatch):
    r = blind.make_record(542)
    assert list(r.hidden) == ["gravity_imbalance"] and r.meta["trajectory"] == "sinusoid"
    path = tmp_path / "rec_542.csv"
    r.write_csv(path)
    prep = prepare(load_record(path))
    monkeypatch.setattr(loop, "PHASE_GUARDED", loop.PHASE_GUARDED - {"asymmetric_friction"})
    without = {a.kind for a in loop.run_loop(prep).accepted}
    assert "asymmetric_friction" in without, "precondition: without the guard the stand-in is named"
    monkeypatch.undo()
    out = loop.run_loop(prep)
    assert "asymmetric_friction" not in {a.kind for a in out.accepted}
    assert any(x["kind"] == "asymmetric_friction" and "the motion is periodic" in x["reason"] for x in out.rejected)


def _write_asymmetric_sinusoid(path, seed: int) -> tuple[float, float]:
    """A rigid axis moved along a sinusoid, torque by inverse dynamics of the motion (no loop), with
    viscous friction 20 N·m·s/rad forward and 32 backward, Coulomb 2 N·m, torque noise 0.02 N·m and a
    2²⁰-count encoder; 250 Hz, 6 periods of 10 s. Returns the true viscous pair."""
    rng = np.random.default_rng(seed)
    fs, period, n_per = 250.0, 10.0, 6
    t = np.arange(0.0, n_per * period, 1.0 / fs)
    w0 = 2.0 * math.pi / period
    amp = 0.6  # rad: 69° of travel either way
    th = amp * (1.0 - np.cos(w0 * t))
    w = amp * w0 * np.sin(w0 * t)
    a = amp * w0**2 * np.cos(w0 * t)
    j, fc, fv_pos, fv_neg = 4.0, 2.0, 20.0, 32.0
    tq = j * a + np.where(w >= 0.0, fv_pos, fv_neg) * w + fc * np.tanh(w / 1e-3) + rng.normal(0.0, 0.02, t.size)
    cpr = 2.0**20 / (2.0 * math.pi)
    pos = np.floor(th * cpr) / cpr
    np.savetxt(path, np.column_stack([t, tq, pos]), fmt="%.12g", delimiter=",",
               header="time_s,torque_nm,position_rad", comments="")
    return fv_pos, fv_neg


def test_a_real_viscous_asymmetry_on_a_sinusoid_passes_the_guard(tmp_path):
    path = tmp_path / "asym_sinusoid.csv"
    fv_pos, fv_neg = _write_asymmetric_sinusoid(path, seed=32)
    prep = prepare(load_record(path))
    out = loop.run_loop(prep)
    assert loop.periodic_motion_hz(prep)[0] is not None, "precondition: the motion is periodic by the rule"
    named = {a.kind: a for a in out.accepted}
    assert "asymmetric_friction" in named, [(x["kind"], x["reason"]) for x in out.rejected]
    fit = out.final
    assert abs(fit.param("viscous_pos") / fv_pos - 1.0) < 0.3
    assert abs(fit.param("viscous_neg") / fv_neg - 1.0) < 0.3
