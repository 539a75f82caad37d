"""A time line against a friction level that varies along the travel (issue 7, session 39;
docs/calibration.md "Session 39").

Friction that depends on the axis angle (a bearing whose load changes with the attitude, cable or
seal drag) is direction-odd torque ``sign(dq)·g(q)``; on a slow run ``q`` is nearly linear in time
and a low-frequency time line took it. The records here are written in the test from the equations
(open loop: the torque is computed from a prescribed motion; no code of ``plant/`` makes them), with
the position quantised like an encoder. The friction profile is a cable drag rising smoothly over
part of the travel — not the blind generator's ``|cos|`` law, on which the change was probed.
"""

import math

import numpy as np
import pytest

from plant.calibration import loop
from plant.calibration.fit import prepare
from plant.calibration.io import Record

FS_HZ = 500.0
COUNTS_PER_RAD = 2**20 / (2 * math.pi)


def _slow_legs(speed_rad_s=0.02, travel_rad=1.2, legs=3):
    """Back-and-forth legs at constant speed with 2 s ramps and 1 s rests: velocity [rad/s] at FS_HZ."""
    ramp = np.linspace(0.0, speed_rad_s, int(2.0 * FS_HZ))
    rest = np.zeros(int(1.0 * FS_HZ))
    n_flat = int((travel_rad / speed_rad_s - 2.0) * FS_HZ)
    segs = [rest]
    for k in range(legs):
        s = 1.0 if k % 2 == 0 else -1.0
        segs += [s * ramp, np.full(n_flat, s * speed_rad_s), s * ramp[::-1], rest]
    return np.concatenate(segs)


def _record(velocity, drag_nm=0.0, line=None, seed=3):
    """Rigid axis (J 2 kg·m², viscous 5 N·m·s/rad, Coulomb 3 N·m); a drag ``drag_nm`` that rises
    as a logistic over the middle of the travel, times sign(v); optional time line ``(A, f)``;
    torque noise 0.05 N·m; a 2^20-count encoder."""
    dt = 1.0 / FS_HZ
    t = np.arange(velocity.size) * dt
    q = np.cumsum(velocity) * dt
    acc = np.gradient(velocity, dt)
    sgn = np.tanh(velocity / 1e-3)
    span = q.max() - q.min()
    drag = drag_nm / (1.0 + np.exp(-(q - (q.min() + 0.6 * span)) / (0.08 * span)))
    tau = 2.0 * acc + 5.0 * velocity + (3.0 + drag) * sgn
    if line is not None:
        tau = tau + line[0] * np.sin(2 * math.pi * line[1] * t + 0.4)
    tau = tau + np.random.default_rng(seed).normal(0.0, 0.05, t.size)
    q_meas = np.floor(q * COUNTS_PER_RAD) / COUNTS_PER_RAD
    return Record(name="travel", t_s=t, position=q_meas, torque=tau)


def _lines(res):
    return [e for e in res.effects() if e.kind == "time_periodic"]


def test_a_drag_along_the_travel_is_not_named_a_time_line():
    """A 1.5 N·m drag over part of the travel: without the test a time line takes it (the defect);
    with it no time line is named and the refusal says why."""
    prep = prepare(_record(_slow_legs(), drag_nm=1.5))
    off = loop.run_loop(prep, cfg=loop.LoopConfig(travel_friction_guard=False))
    assert _lines(off), "the record no longer shows the defect the test is for"
    res = loop.run_loop(prep)
    assert not _lines(res), [e.params() for e in _lines(res)]
    assert any(r["kind"] == "time_periodic" and "varies along the travel" in r["reason"] for r in res.rejected)


def test_a_real_line_on_the_same_motion_is_still_named():
    """A 0.4 N·m line at 0.37 Hz (many cycles per leg) on the same motion, no drag: named within 3 %."""
    res = loop.run_loop(prepare(_record(_slow_legs(), line=(0.4, 0.37))))
    lines = _lines(res)
    assert len(lines) == 1
    ev = [a.evidence for a in res.accepted if a.kind == "time_periodic"][0]
    assert "still predicts with a friction level that varies along the travel" in ev
    assert lines[0].frequency_hz == pytest.approx(0.37, rel=0.03)
    assert lines[0].amplitude_nm == pytest.approx(0.4, rel=0.3)


def test_a_real_line_beside_a_drag_is_still_named():
    """Both: the drag is not a time line, the 0.37 Hz line is."""
    res = loop.run_loop(prepare(_record(_slow_legs(), drag_nm=1.5, line=(0.4, 0.37))))
    freqs = [e.frequency_hz for e in _lines(res)]
    assert len(freqs) == 1 and freqs[0] == pytest.approx(0.37, rel=0.03), freqs
