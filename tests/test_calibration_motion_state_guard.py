"""A time line at the motion's own frequency on a sinusoid of fewer than 3 cycles (docs/calibration.md
"Session 26": a known defect; "Session 47": fixed).

On a sinusoidal motion, ``q = A(1 − cos ωt)`` and ``dq = Aω sin ωt``, so a torque line at ω is
``a·dq + b·q`` exactly: a torque that depends on the position (a cable wrap's spring, an
unmodelled imbalance over a short travel) looks like a disturbance at the motion's own frequency.
Until session 47 the phase guard of session 18 needed 3 cycles, and the test against a flexible
function of the velocity alone let such a line through (blind record 284; session 26 kept this as a
strict xfail). Session 47: a motion that 3 harmonics describe is periodic from 2 cycles
(``loop.PERIODIC_MIN_CYCLES_SINUSOID``), so the guard holds the motion's own lines there too. Records
written in the test from the equations (open loop, the torque computed from a prescribed motion; no
code of ``plant/`` makes them).
"""

import math

import numpy as np
import pytest

from plant.calibration import loop
from plant.calibration.fit import prepare
from tests.test_calibration_phase_guard import FS_HZ, _record


def _sinusoid_motion(period_s=12.0, cycles=2.5, amplitude_rad=0.5):
    """``q = A(1 − cos ωt)``: the velocity ``Aω sin ωt`` [rad/s], and ω / 2π [Hz]."""
    t = np.arange(int(cycles * period_s * FS_HZ)) / FS_HZ
    w = 2 * math.pi / period_s
    return amplitude_rad * w * np.sin(w * t), 1.0 / period_s


def _near(f_hz, f0, t_span):
    return abs(f_hz - f0) < 1.0 / t_span


def test_a_position_dependent_torque_is_not_named_a_line_at_the_motions_frequency(monkeypatch):
    """2 N·m/rad about the middle of the travel on 2.5 cycles: without the two-cycle search the guard is
    off and a line at the motion's frequency is named (the defect, checked); with it the motion is
    periodic and no such line is named."""
    v, f0 = _sinusoid_motion()
    spring_nm_rad = 2.0  # assumed: a cable-wrap-like torque, 2 N·m per rad about the middle of the travel
    rec = _record(v, torque_extra=lambda t, q: spring_nm_rad * (q - 0.5))
    prep = prepare(rec)
    t_span = float(rec.t_s[-1] - rec.t_s[0])
    monkeypatch.setattr(loop, "PERIODIC_MIN_CYCLES_SINUSOID", loop.PERIODIC_MIN_CYCLES)
    assert loop.periodic_motion_hz(prep)[0] is None
    lines = [e for e in loop.run_loop(prep).effects() if e.kind == "time_periodic"]
    assert any(_near(e.frequency_hz, f0, t_span) for e in lines), "the record no longer shows the defect"
    monkeypatch.undo()
    f, _ = loop.periodic_motion_hz(prep)
    assert f == pytest.approx(f0, rel=0.01)
    result = loop.run_loop(prep)
    lines = [e for e in result.effects() if e.kind == "time_periodic"]
    assert not any(_near(e.frequency_hz, f0, t_span) for e in lines), [e.frequency_hz for e in lines]


def test_a_disturbance_away_from_the_motions_lines_is_still_found():
    v, _ = _sinusoid_motion()
    f_d = 1.37  # Hz, far from the motion's 0.083 Hz and its harmonics
    rec = _record(v, torque_extra=lambda t, q: 0.5 * np.sin(2 * math.pi * f_d * t))
    result = loop.run_loop(prepare(rec))
    lines = [e for e in result.effects() if e.kind == "time_periodic"]
    assert any(abs(e.frequency_hz - f_d) < 0.01 * f_d for e in lines)


def test_under_two_cycles_a_sinusoid_is_not_periodic():
    """1.6 cycles: below ``PERIODIC_MIN_CYCLES_SINUSOID`` the record cannot tell a period from a slow
    function of time; the guard stays off."""
    v, _ = _sinusoid_motion(cycles=1.6)
    assert loop.periodic_motion_hz(prepare(_record(v)))[0] is None


def test_two_back_and_forth_legs_at_different_speeds_are_not_periodic():
    """Two out-and-back legs at 0.02 and 0.08 rad/s (2 "cycles" of direction, not of a period): the
    second search asks 3 harmonics of one fundamental to explain 95 % of the velocity, which this
    motion does not give, so the guard stays off."""
    segs = []
    for speed in (0.02, 0.08):
        ramp = np.linspace(0.0, speed, int(1.0 * FS_HZ))
        leg = np.concatenate([ramp, np.full(int(10.0 * FS_HZ), speed), ramp[::-1]])
        segs += [leg, -leg]
    f, share = loop.periodic_motion_hz(prepare(_record(np.concatenate(segs))))
    assert f is None and share < loop.PERIODIC_MIN_SHARE
