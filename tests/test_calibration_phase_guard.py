"""The phase guard: on a periodic motion a smooth term must predict beyond any smooth function of the
motion's phase (issue 7, session 18; docs/calibration.md "Session 18").

The records here are written in the test from the equations (open loop: the torque is computed from
a prescribed motion; no code of ``plant/`` makes them), with the position quantised like an encoder.
"""

import math

import numpy as np
import pytest

from plant.calibration import loop
from plant.calibration.fit import PHASE_HARMONICS, prepare
from plant.calibration.io import Record

FS_HZ = 500.0
COUNTS_PER_RAD = 2**20 / (2 * math.pi)


def _record(velocity: np.ndarray, torque_extra=None, seed: int = 0, name: str = "rec") -> Record:
    """A rigid axis (J 2 kg·m², viscous 5 N·m·s/rad, Coulomb 3 N·m, offset 0.5 N·m) following
    ``velocity`` [rad/s] at ``FS_HZ``; torque noise 0.05 N·m; a 2^20-count encoder."""
    dt = 1.0 / FS_HZ
    t = np.arange(velocity.size) * dt
    q = np.cumsum(velocity) * dt
    acc = np.gradient(velocity, dt)
    tau = 2.0 * acc + 5.0 * velocity + 3.0 * np.tanh(velocity / 1e-3) + 0.5
    if torque_extra is not None:
        tau = tau + torque_extra(t, q)
    tau = tau + np.random.default_rng(seed).normal(0.0, 0.05, t.size)
    q_meas = np.floor(q * COUNTS_PER_RAD) / COUNTS_PER_RAD
    return Record(name=name, t_s=t, position=q_meas, torque=tau)


def _sinusoid(period_s=10.0, cycles=5, amplitude_rad=0.5):
    t = np.arange(int(cycles * period_s * FS_HZ)) / FS_HZ
    w = 2 * math.pi / period_s
    return amplitude_rad * w * np.cos(w * t), 1.0 / period_s


def _staircase():
    levels = 0.4 * np.logspace(-1.5, 0.0, 6)
    segs = [np.zeros(int(0.5 * FS_HZ))]
    for v in levels:
        n = int(min(max(0.6 / v, 1.0), 6.0) * FS_HZ)
        ramp = np.linspace(0, v, int(0.2 * FS_HZ))
        segs += [ramp, np.full(n, v), ramp[::-1], -ramp, np.full(n, -v), -ramp[::-1]]
    segs.append(np.zeros(int(0.5 * FS_HZ)))
    return np.concatenate(segs)


def test_a_sinusoid_motion_is_periodic_at_its_own_frequency():
    v, f0 = _sinusoid()
    f, share = loop.periodic_motion_hz(prepare(_record(v)))
    assert f == pytest.approx(f0, rel=0.005)
    assert share > 0.99


@pytest.mark.parametrize("cycles", [3, 4])
def test_a_record_of_exactly_three_or_four_periods_counts(cycles):
    v, f0 = _sinusoid(period_s=12.0, cycles=cycles)
    f, _ = loop.periodic_motion_hz(prepare(_record(v)))
    assert f == pytest.approx(f0, rel=0.005)


def test_a_staircase_is_not_periodic():
    f, share = loop.periodic_motion_hz(prepare(_record(_staircase())))
    assert f is None and share < loop.PERIODIC_MIN_SHARE


def _line(k: int, f0: float, amp_nm: float = 0.5):
    """A torque line at the k-th harmonic of the motion, ``A sin(k·2π f0 t)``."""
    return lambda t, q: amp_nm * np.sin(2 * math.pi * k * f0 * t)


def _run(rec):
    return loop.run_loop(prepare(rec))


def test_a_line_at_the_third_harmonic_of_a_periodic_motion_is_refused_and_says_why():
    """sin(3ωt) is a function of the position on q = A sin ωt: on this record nothing tells it from a
    torque that depends on where the axis is in its cycle, so the guard refuses it, with its reason."""
    v, f0 = _sinusoid()
    assert PHASE_HARMONICS >= 3
    res = _run(_record(v, _line(3, f0)))
    assert [a.kind for a in res.accepted if a.kind == "time_periodic"] == []
    reasons = [r["reason"] for r in res.rejected if r["kind"] == "time_periodic"]
    assert any(r.startswith("the motion is periodic") for r in reasons), reasons


def test_a_line_beyond_the_guarded_harmonics_is_still_named_at_its_frequency():
    v, f0 = _sinusoid()
    k = PHASE_HARMONICS + 2
    res = _run(_record(v, _line(k, f0)))
    kinds = [a.kind for a in res.accepted]
    assert "time_periodic" in kinds
    fit = res.final
    assert any(abs(f - k * f0) / (k * f0) < 0.01 for f in fit.spec.time_frequencies)


def test_the_same_line_on_a_non_periodic_motion_is_named():
    """Without a periodic motion there is no guard: a 0.3 Hz line on a staircase is found."""
    res = _run(_record(_staircase(), lambda t, q: 0.5 * np.sin(2 * math.pi * 0.3 * t)))
    assert "time_periodic" in [a.kind for a in res.accepted]
    assert not any(r["reason"].startswith("the motion is periodic") for r in res.rejected)


def test_a_line_within_one_frequency_bin_of_a_harmonic_is_refused_as_unresolvable():
    """2·f0 + 0.3/T: 0.3 cycles of drift against the harmonic over the record, so the harmonic in
    the model does not absorb it, but the record cannot resolve it from the harmonic (Rayleigh)."""
    v, f0 = _sinusoid()
    T = v.size / FS_HZ
    f_line = 2 * f0 + 0.3 / T
    res = _run(_record(v, lambda t, q: 0.5 * np.sin(2 * math.pi * f_line * t)))
    assert "time_periodic" not in [a.kind for a in res.accepted]
    reasons = [r["reason"] for r in res.rejected if r["kind"] == "time_periodic"]
    assert any("within one frequency bin" in r and "harmonic 2" in r for r in reasons), reasons


def test_a_line_two_bins_from_a_harmonic_is_named():
    v, f0 = _sinusoid()
    T = v.size / FS_HZ
    f_line = 2 * f0 + 2.5 / T
    res = _run(_record(v, lambda t, q: 0.5 * np.sin(2 * math.pi * f_line * t)))
    assert "time_periodic" in [a.kind for a in res.accepted]
    assert any(abs(f - f_line) / f_line < 0.01 for f in res.final.spec.time_frequencies)
