"""The periodic motion's fundamental is its shortest period (issue 7, session 33; docs/calibration.md
"Session 33").

A sub-harmonic ``f/n`` of a periodic motion explains all that ``f`` does (its n-th harmonic is ``f``)
and fits the noise on its extra lines besides, so by the share alone it wins by a hair; the phase
guard then holds only ``K/n`` of the motion's harmonics. Found on fixed seeds 12 and 34 (sinusoids of
6 cycles detected at half their frequency). The records here are written in the test from the
equations (open loop, torque computed from a prescribed motion; no code of ``plant/`` makes them),
with an encoder-quantised position.
"""

import math

import numpy as np
import pytest

from plant.calibration import loop
from plant.calibration.fit import prepare
from plant.calibration.io import Record

FS_HZ = 250.0
COUNTS_PER_RAD = 2**22 / (2 * math.pi)


def _record(velocity: np.ndarray, torque_extra=None, seed: int = 0) -> Record:
    """A rigid axis (J 4 kg·m², viscous 20 N·m·s/rad, Coulomb 2 N·m, offset 0.3 N·m) following
    ``velocity`` [rad/s] at ``FS_HZ``; torque noise 0.02 N·m; a 2^22-count encoder."""
    dt = 1.0 / FS_HZ
    t = np.arange(velocity.size) * dt
    q = np.cumsum(velocity) * dt
    acc = np.gradient(velocity, dt)
    tau = 4.0 * acc + 20.0 * velocity + 2.0 * np.tanh(velocity / 1e-3) + 0.3
    if torque_extra is not None:
        tau = tau + torque_extra(t, q)
    tau = tau + np.random.default_rng(seed).normal(0.0, 0.02, t.size)
    q_meas = np.floor(q * COUNTS_PER_RAD) / COUNTS_PER_RAD
    return Record(name="fundamental", t_s=t, position=q_meas, torque=tau)


def _velocity(period_s: float, cycles: int, lines=((1, 1.0),), v_amp: float = 0.1) -> np.ndarray:
    """``v_amp · Σ a·sin(k·2π t / period_s)`` over ``cycles`` periods [rad/s]."""
    t = np.arange(int(round(cycles * period_s * FS_HZ))) / FS_HZ
    return v_amp * sum(a * np.sin(2 * math.pi * k * t / period_s) for k, a in lines)


@pytest.mark.parametrize("cycles", [6, 7, 9])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_sinusoid_of_six_or_more_cycles_is_periodic_at_its_own_frequency(cycles, seed):
    """With ≥ 6 cycles its half-frequency has ≥ 3 cycles too and is searched (the peak may be a
    harmonic); the motion's own frequency must win."""
    v = _velocity(30.0, cycles)
    f, share, k = loop.periodic_motion(prepare(_record(v, seed=seed)))
    assert f == pytest.approx(1 / 30.0, rel=0.005)
    assert k == 3 and share > 0.99


def test_a_motion_whose_strongest_line_is_its_second_harmonic_is_found_at_its_fundamental():
    """Velocity 0.35·sin ωt + sin 2ωt: the spectrum peaks at 2f₀, whose own harmonics leave the f₀
    line (11 % of the variance) out; the search around half the peak finds f₀."""
    f0 = 1 / 20.0
    v = _velocity(20.0, 6, lines=((1, 0.35), (2, 1.0)))
    f, share, _ = loop.periodic_motion(prepare(_record(v)))
    assert f == pytest.approx(f0, rel=0.005)
    assert share >= loop.PERIODIC_MIN_SHARE


def test_a_line_at_the_motions_second_harmonic_is_held_by_the_guard_on_a_six_cycle_sinusoid():
    """A 0.4 N·m line at 2f₀ is a function of the phase of a sinusoid: refused by the phase guard
    (at f₀/2 the guard held f₀/2, f₀, 3f₀/2 and the line passed as a time line)."""
    f0 = 1 / 30.0
    v = _velocity(30.0, 6)
    rec = _record(v, lambda t, q: 0.4 * np.sin(2 * math.pi * 2 * f0 * t + 0.3))
    res = loop.run_loop(prepare(rec))
    assert "time_periodic" not in [a.kind for a in res.accepted]
    reasons = [r["reason"] for r in res.rejected if r["kind"] == "time_periodic"]
    assert any(r.startswith("the motion is periodic") and "harmonic 2" in r for r in reasons), reasons
