"""The fit band must not change the baseline: torque and columns masked alike at rest (session 28).

Written from the equations, with its own record generator (nothing from the project's two
generators): a rigid axis ``τ = J·a + fv·v + fc·sign(v) + offset + noise`` while it moves, sweeping
back and forth with dwells at rest. At rest the friction balances whatever torque the drive holds,
anything within the static band: here a level drawn per dwell, so the model's Coulomb column
(ramped across the rest) is wrong there by up to ±Fs, as on every real servo record.

A decimation filter applied alike to the torque and to the model's columns cannot raise the rms
of a residual or move the coefficients; the error at rest, spread by the filter's reach into the
moving samples the fit keeps, did both (docs/calibration.md, "Session 28": on the 10⁶-sample record
the Coulomb level came out 8 % low at the 10 Hz fit band a long record gets).
"""
from __future__ import annotations

import numpy as np
import pytest

from plant.calibration.fit import ModelSpec, fit_model, filter_reach, prepare
from plant.calibration.io import Record

J, FV, FC, OFFSET = 4.0, 30.0, 6.0, -0.3   # kg·m², N·m·s/rad, N·m, N·m (assumed: an RA-like axis)
FS_RATIO = 1.3                              # static/Coulomb (assumed)
NOISE_NM = 0.05
FS_HZ = 200.0


def _record(seed: int, duration_s: float = 240.0) -> Record:
    rng = np.random.default_rng(seed)
    dt = 1.0 / FS_HZ
    v_seg: list[np.ndarray] = []
    hold: list[np.ndarray] = []
    direction = 1.0
    while sum(s.size for s in v_seg) * dt < duration_s:
        vmax = rng.uniform(0.05, 0.3)                  # rad/s
        t_acc = rng.uniform(0.15, 0.4)                 # s, cosine ramp up and down
        t_run = rng.uniform(2.0, 6.0)                  # s at speed
        t_dwell = rng.uniform(0.3, 1.2)                # s at rest
        ramp = 0.5 * (1 - np.cos(np.pi * np.arange(int(t_acc / dt)) / int(t_acc / dt)))
        prof = np.r_[ramp, np.ones(int(t_run / dt)), ramp[::-1]] * vmax * direction
        dwell = np.zeros(int(t_dwell / dt))
        v_seg += [prof, dwell]
        # the torque held at rest: anywhere in the static band, drawn per dwell
        hold += [np.full(prof.size, np.nan), np.full(dwell.size, rng.uniform(-FS_RATIO * FC, FS_RATIO * FC))]
        direction = -direction
    v = np.concatenate(v_seg)
    held = np.concatenate(hold)
    n = v.size
    t = np.arange(n) * dt
    a = np.gradient(v, dt)
    q = np.cumsum(v) * dt
    counts_per_rad = 2**24 / (2 * np.pi)
    q_meas = np.round(q * counts_per_rad) / counts_per_rad
    tau = J * a + FV * v + FC * np.sign(v) + OFFSET
    tau = np.where(np.isnan(held), tau, held) + rng.normal(0.0, NOISE_NM, n)
    return Record(name=f"rest_mask_{seed}", t_s=t, position=q_meas, torque=tau)


def _baseline(rec: Record, decimate: int) -> tuple[dict[str, float], float]:
    prep = prepare(rec, decimate=decimate)
    fit = fit_model(prep, ModelSpec())
    coef = dict(zip(fit.names, (float(c) for c in fit.coef)))
    return coef, float(np.sqrt(fit.rss / prep.y_dec.size))


@pytest.mark.parametrize("seed", [1, 2])
def test_baseline_does_not_depend_on_a_coarse_fit_band(seed: int) -> None:
    rec = _record(seed)
    fine, rms_fine = _baseline(rec, 8)       # 25 Hz fit
    coarse, rms_coarse = _baseline(rec, 20)  # 10 Hz fit (what a 10⁶-sample record at 200 Hz gets)
    for name, truth in (("inertia", J), ("viscous", FV), ("coulomb", FC)):
        for c in (fine, coarse):
            assert c[name] == pytest.approx(truth, rel=0.02), (name, fine[name], coarse[name])
        assert coarse[name] == pytest.approx(fine[name], rel=0.01), name
    for c in (fine, coarse):
        assert c["offset"] == pytest.approx(OFFSET, abs=0.05)
    # a narrower low-pass applied alike to torque and columns cannot raise the residual
    assert rms_coarse <= rms_fine * 1.05, (rms_fine, rms_coarse)


def test_standard_band_is_not_masked() -> None:
    """At the standard ≈ 100 Hz fit (decimation round(fs/100)) nothing is masked: there the loop's
    rules were built with the leakage present, and the mask lost as many records as it gained."""
    rec = _record(3, duration_s=60.0)
    assert prepare(rec).rest_mask is None
    assert prepare(rec).decim == 2
    coarse = prepare(rec, decimate=10)
    assert coarse.rest_mask is not None and 0.0 < coarse.rest_mask.mean() < 1.0


def test_filter_reach_of_the_position_filter() -> None:
    """Session 6's definition: 13 samples hold 99.9 % of the order-4 Butterworth at fs/10 (filtfilt)."""
    from scipy import signal

    b, a = signal.butter(4, 0.2)
    assert filter_reach(b, a) == 13
    # a narrower filter reaches further
    b2, a2 = signal.butter(4, 0.05)
    assert filter_reach(b2, a2) > 3 * 13
