"""NOT IN MAIN (session 30: the change it checks failed its bar 2; README.md here). Runs only with change.diff applied.

A friction warm-up is described as one, and no library kind stands in for it (session 30).

Written from the equations, with its own record generator (nothing from the project's two
generators): a rigid axis ``τ = J·a + (fv·v + fc·sign v)·(1 + d·exp(−t/τw)) + offset + noise``,
sweeping back and forth at random speeds. The friction level relaxes exponentially to its running
value, as the lubricant warms: the textbook first-order warm-up. The loop's out-of-library
``friction_drift`` description carries a first-order term ``exp(−τ/ρ)`` (τ the record's normalised
time) since session 30; before, it was a quadratic in τ, which misses an exponential with a time
constant of a fifth of the record by up to 17 % of the drift, and on long records time lines took
what it left (docs/calibration.md, "Session 30").
"""
from __future__ import annotations

import numpy as np
import pytest

from plant.calibration.fit import ModelSpec, fit_model, prepare
from plant.calibration.io import Record
from plant.calibration.loop import run_loop

J, FV, FC, OFFSET = 4.0, 30.0, 6.0, 0.2   # kg·m², N·m·s/rad, N·m, N·m (assumed: an RA-like axis)
NOISE_NM = 0.05
FS_HZ = 200.0


def _record(seed: int, drift: float, tau_w_frac: float, duration_s: float = 400.0) -> Record:
    rng = np.random.default_rng(seed)
    dt = 1.0 / FS_HZ
    segs: list[np.ndarray] = []
    direction = 1.0
    while sum(s.size for s in segs) * dt < duration_s:
        vmax = rng.uniform(0.05, 0.3)                     # rad/s
        n_acc = int(rng.uniform(0.2, 0.5) / dt)           # cosine ramps up and down
        ramp = 0.5 * (1 - np.cos(np.pi * np.arange(n_acc) / n_acc))
        segs.append(np.r_[ramp, np.ones(int(rng.uniform(3.0, 8.0) / dt)), ramp[::-1]] * vmax * direction)
        direction = -direction
    v = np.concatenate(segs)
    n = v.size
    t = np.arange(n) * dt
    a = np.gradient(v, dt)
    q = np.cumsum(v) * dt
    counts_per_rad = 2**24 / (2 * np.pi)
    q_meas = np.round(q * counts_per_rad) / counts_per_rad
    level = 1.0 + drift * np.exp(-t / (tau_w_frac * t[-1]))
    tau = J * a + (FV * v + FC * np.sign(v)) * level + OFFSET + rng.normal(0.0, NOISE_NM, n)
    return Record(name=f"warmup_{seed}", t_s=t, position=q_meas, torque=tau)


@pytest.mark.parametrize("seed, drift, tau_w_frac", [(1, 0.4, 0.12), (2, 0.25, 0.3)])
def test_a_warm_up_is_described_by_the_drift_with_its_time_constant_and_no_library_kind(seed, drift, tau_w_frac):
    """No library kind is named, the drift is the first out-of-library structure reported, its ρ
    comes out within 15 % of the warm-up's time constant, and with it the fit is as good as the
    same record's fit without any warm-up (same trajectory and noise)."""
    prep = prepare(_record(seed, drift, tau_w_frac))
    res = run_loop(prep)
    assert [a.kind for a in res.accepted] == [], [a.kind for a in res.accepted]
    assert res.unexplained and res.unexplained[0].get("kind") == "friction_drift", res.unexplained
    rho = res.final.spec.drift_rho
    assert rho is not None and abs(rho / tau_w_frac - 1.0) < 0.15, (rho, tau_w_frac)
    with_drift = fit_model(prep, ModelSpec(nuisance=["friction_drift"], drift_rho=rho), refine=False)
    no_warm_up = fit_model(prepare(_record(seed, 0.0, tau_w_frac)), ModelSpec(), refine=False)
    assert with_drift.rms <= 1.05 * no_warm_up.rms, (with_drift.rms, no_warm_up.rms)
