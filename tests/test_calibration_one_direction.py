"""Direction-dependent friction needs motion in both directions (issue 7; docs/calibration.md, "Session 32").

On a record whose axis moves one way only, the other direction's friction is not in the record, so
``asymmetric_friction`` is not tried and the report says why. Found on clean blind seed 632 (the blind
generator, written without reading the loop: ``plant/calibration/blind_records.py``), where main named
an asymmetric friction that explained 0.026 % of the residual with ``viscous_neg = coulomb_neg = 0``.
The second test is a record written here from the equations: a rigid axis moved both ways with a
real viscous asymmetry keeps it.
"""

from __future__ import annotations

import math

import numpy as np

from plant.calibration import blind_records as blind
from plant.calibration import loop
from plant.calibration.fit import prepare
from plant.calibration.io import load_record


def test_blind_632_one_way_motion_names_no_asymmetry(tmp_path, monkeypatch):
    r = blind.make_record(632)
    assert list(r.hidden) == []
    path = tmp_path / "rec_632.csv"
    r.write_csv(path)
    prep = prepare(load_record(path))
    n_pos, n_neg = loop.both_directions(prep)
    assert min(n_pos, n_neg) < loop.MIN_SAMPLES_PER_DIRECTION <= max(n_pos, n_neg), "precondition: one-way motion"
    monkeypatch.setattr(loop, "MIN_SAMPLES_PER_DIRECTION", 0)
    # the rule on its own: since session 51 the share floor would also refuse this 0.03 % asymmetry
    monkeypatch.setattr(loop, "_below_share_floor", lambda c, cfg: None)
    without = {a.kind for a in loop.run_loop(prep).accepted}
    assert "asymmetric_friction" in without, "precondition: without the rule the asymmetry is named"
    monkeypatch.undo()
    out = loop.run_loop(prep)
    assert out.accepted == []
    assert any(x["kind"] == "asymmetric_friction" and "one way only" in x["reason"] for x in out.rejected)


def test_a_real_asymmetry_on_two_way_motion_is_still_named(tmp_path):
    """Open loop, inverse dynamics: back-and-forth passes at four speeds, viscous friction 20 N·m·s/rad
    forward and 30 backward, Coulomb 1.5 N·m, torque noise 0.02 N·m, a 2²⁰-count encoder, 500 Hz."""
    rng = np.random.default_rng(632)
    fs = 500.0
    v = np.concatenate([np.zeros(500)] + [np.full(2000, s * lvl) for lvl in (0.02, 0.05, 0.1, 0.2) for s in (1.0, -1.0)]
                       + [np.zeros(500)])
    v = np.convolve(v, np.ones(100) / 100.0, mode="same")          # 0.2 s ramps
    t = np.arange(v.size) / fs
    th = np.cumsum(v) / fs
    a = np.gradient(v, 1.0 / fs)
    tq = 3.0 * a + np.where(v >= 0.0, 20.0, 30.0) * v + 1.5 * np.tanh(v / 1e-3) + rng.normal(0.0, 0.02, v.size)
    cpr = 2.0**20 / (2.0 * math.pi)
    path = tmp_path / "two_way.csv"
    np.savetxt(path, np.column_stack([t, tq, np.floor(th * cpr) / cpr]), fmt="%.12g", delimiter=",",
               header="time_s,torque_nm,position_rad", comments="")
    prep = prepare(load_record(path))
    assert min(loop.both_directions(prep)) >= loop.MIN_SAMPLES_PER_DIRECTION
    out = loop.run_loop(prep)
    assert "asymmetric_friction" in {a.kind for a in out.accepted}, [(x["kind"], x["reason"]) for x in out.rejected]
    assert abs(out.final.param("viscous_pos") / 20.0 - 1.0) < 0.3
    assert abs(out.final.param("viscous_neg") / 30.0 - 1.0) < 0.3
