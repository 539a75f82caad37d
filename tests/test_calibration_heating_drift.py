"""The friction drift as a heating: lags of the friction power (issue 7, session 49).

A friction level that follows a temperature warmed by the friction's own dissipation is not a
function of time: on a staircase whose speeds grow, or whose directions alternate, it differs
between the legs of each direction, and a description in time alone (τ with τ² or a warm-up
``exp(−t/T)``, session 48) left that difference to asymmetric friction (independent 20209, 20333,
20337; docs/calibration.md, "Session 49"). The loop now also tries the Coulomb and viscous columns
times first-order lags of ``|dq|`` and ``dq²``, and keeps them only where they predict held-out
blocks better than the warm-up with a free function of the speed beside it.

On the records of this file (alternating slow positive and fast negative legs) the time-only
description found nothing at all; the heating is described, its time constant within 1 % (44.4–44.9 s
for 45 s on seeds 0–3; the test allows 15 %).

The records here are made by inverse dynamics of a prescribed motion in this file: its own
staircase, friction law, and temperature integrated by forward Euler from the friction power it
dissipates (not the loop's ``lfilter``), with quantisation and noise.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from plant.calibration import loop
from plant.calibration.fit import heating_shapes, prepare
from plant.calibration.io import Record
from plant.calibration.loop import LoopConfig, run_loop


def _heating_record(seed: int, beta: float = 0.3, tau_s: float = 45.0) -> tuple[Record, float]:
    """A 300 s staircase at 500 Hz of 10 legs of 30 s alternating between slow positive speeds
    (0.004–0.01 rad/s) and fast negative ones (0.03–0.05 rad/s), 0.5 s ramps; friction
    ``(1 − β·T)(Fv·v + Fc·tanh(v/1e-4))`` with ``dT/dt = (P/P̄ − T)/τ``, ``P`` the power of the friction
    at T = 0 and ``P̄`` its mean (so that τ is the temperature's own time constant); 24-bit position,
    0.02 N·m noise. The fast legs heat and the slow ones cool: the friction is lower going negative
    on average, and it rises and falls within each leg. Returns the record and τ [s]."""
    rng = np.random.default_rng(seed)
    fs, duration, n_leg = 500.0, 300.0, 10
    t = np.arange(0.0, duration, 1.0 / fs)
    leg = np.minimum((t / (duration / n_leg)).astype(int), n_leg - 1)
    slow = rng.uniform(0.004, 0.01, size=n_leg // 2)
    fast = -rng.uniform(0.03, 0.05, size=n_leg // 2)
    v_raw = np.column_stack([slow, fast]).ravel()[leg]
    k = int(0.5 * fs)
    v = np.convolve(np.pad(v_raw, (k, k), mode="edge"), np.ones(k) / k, mode="same")[k:-k]
    q = np.cumsum(v) / fs
    acc = np.gradient(v, 1.0 / fs)
    inertia, fv, fc = rng.uniform(5.0, 20.0), rng.uniform(20.0, 60.0), rng.uniform(0.5, 1.5)
    f0 = fv * v + fc * np.tanh(v / 1e-4)
    power = np.abs(f0 * v)
    p_ref = float(np.mean(power))
    temp = np.empty_like(t)
    x, h = 0.0, 1.0 / fs
    for i in range(t.size):              # forward Euler, the test's own integrator
        temp[i] = x
        x += h * (power[i] / p_ref - x) / tau_s
    torque = inertia * acc + (1.0 - beta * temp) * f0 + rng.normal(0.0, 0.02, t.size)
    quantum = 2 * np.pi / 2**24
    return Record(name=f"heating{seed}", t_s=t, position=np.round(q / quantum) * quantum, torque=torque), tau_s


def test_heating_shapes_are_first_order_lags_of_the_power_parts():
    """On a step of speed the lag of |w| is ``1 − exp(−t/T)`` (before the scaling to mean 1)."""
    dt, T = 0.01, 5.0
    t = np.arange(0.0, 30.0, dt)
    w = np.full_like(t, -0.2)
    x1, x2 = heating_shapes(w, dt, T)
    ref = 1.0 - np.exp(-(t + dt) / T)     # the discrete lag sees the first sample as one step of heating
    np.testing.assert_allclose(x1, ref / ref.mean(), rtol=2e-3)
    np.testing.assert_allclose(x2, x1, rtol=1e-12)
    assert math.isclose(float(np.mean(x1)), 1.0, rel_tol=1e-12)
    z1, z2 = heating_shapes(np.zeros(100), dt, T)
    assert not z1.any() and not z2.any()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_heating_is_described_and_no_library_kind_is_named(seed):
    rec, tau_s = _heating_record(seed)
    res = run_loop(prepare(rec), None, LoopConfig())
    assert [a.kind for a in res.accepted] == []
    drift = [o for o in res.out_of_library if o.get("kind") == "friction_drift"]
    assert len(drift) == 1
    assert drift[0]["shape"] == "heating"
    assert "the heating's time constant" in drift[0]["note"]
    assert drift[0]["time_constant_s"] == pytest.approx(tau_s, rel=0.15)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_warm_up_alone_misses_it(seed, monkeypatch):
    """The defect: with the drift a function of time only (sessions 48 and before) the heating is
    either named a library kind or not described at all (on these records: not described — the
    temperature rises and falls with the legs, which no function of time follows)."""
    monkeypatch.setattr(loop, "DRIFT_SHAPES", ("warm-up",))
    rec, _ = _heating_record(seed)
    res = run_loop(prepare(rec), None, LoopConfig())
    drift = [o for o in res.out_of_library if o.get("kind") == "friction_drift"]
    assert [a.kind for a in res.accepted] != [] or drift == []
