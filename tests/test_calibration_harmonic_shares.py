"""The harmonic shares behind the phase guard, against their definition.

``loop._harmonic_shares`` orthogonalises the harmonic columns through the Cholesky factor of their
Gram matrix (session 30: a quarter of the time of the QR it replaced). Its definition is plain:
entry K − 1 is the share of the velocity's variance that a least-squares fit of a constant and
the harmonics 1..K explains. These tests compute that fit directly, one ``lstsq`` per K, on
randomised velocities (sweeps, sinusoids, noise) and record lengths.
"""

from __future__ import annotations

import numpy as np
import pytest

from plant.calibration import loop


def _shares_by_definition(t: np.ndarray, v: np.ndarray, f: float, k_max: int) -> np.ndarray:
    """1 − RSS_K / Σ(v − v̄)² for K = 1..k_max, each RSS from its own least-squares fit."""
    v0 = v - v.mean()
    var = float(v0 @ v0)
    out = []
    for k_top in range(1, k_max + 1):
        cols = [np.ones_like(t)]
        for k in range(1, k_top + 1):
            cols += [np.sin(2 * np.pi * k * f * t), np.cos(2 * np.pi * k * f * t)]
        X = np.column_stack(cols)
        coef, *_ = np.linalg.lstsq(X, v, rcond=None)
        r = v - X @ coef
        out.append(1.0 - float(r @ r) / var)
    return np.array(out)


@pytest.mark.parametrize("seed", range(12))
def test_shares_equal_the_least_squares_fit_of_each_number_of_harmonics(seed):
    """Every entry equals the share explained by its own least-squares fit, to 1e-10."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(500, 20_000))
    dt = float(rng.uniform(0.002, 0.02))
    t = np.arange(n) * dt
    f0 = float(rng.uniform(3.0 / t[-1], 0.1 / dt))
    kind = seed % 3
    if kind == 0:      # a back-and-forth sweep: square-ish velocity
        v = np.sign(np.sin(2 * np.pi * f0 * t + rng.uniform(0, 2 * np.pi))) * rng.uniform(0.01, 1.0)
    elif kind == 1:    # a sinusoid with an offset
        v = rng.uniform(0.01, 1.0) * np.sin(2 * np.pi * f0 * t + rng.uniform(0, 2 * np.pi)) + rng.uniform(-0.2, 0.2)
    else:              # no periodic motion at all
        v = np.cumsum(rng.standard_normal(n)) * 1e-3
    v = v + rng.uniform(0.0, 0.2) * np.std(v) * rng.standard_normal(n)
    f = f0 * float(rng.uniform(0.95, 1.05))
    k_max = int(rng.integers(3, 16))
    v0 = v - v.mean()
    got = loop._harmonic_shares(t, v, float(v0 @ v0), f, k_max)
    want = _shares_by_definition(t, v, f, k_max)
    assert got.shape == (k_max,)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-10)


def test_a_pure_harmonic_is_explained_at_its_own_number_and_not_before():
    """A velocity made of the 1st and 4th harmonics: K = 1..3 explain only the first, K ≥ 4 all."""
    t = np.arange(6000) * 0.01
    f = 0.1
    a1, a4 = 1.0, 0.5
    v = a1 * np.sin(2 * np.pi * f * t) + a4 * np.cos(2 * np.pi * 4 * f * t)
    v0 = v - v.mean()
    s = loop._harmonic_shares(t, v, float(v0 @ v0), f, 6)
    first = a1**2 / (a1**2 + a4**2)
    np.testing.assert_allclose(s[:3], first, atol=1e-9)
    np.testing.assert_allclose(s[3:], 1.0, atol=1e-9)


def test_coinciding_columns_give_the_definition_not_an_error():
    """At f = 0 every sine is 0 and every cosine is the constant (a singular Gram matrix): the
    shares are still the least-squares ones, 0 for every K, and nothing is raised."""
    rng = np.random.default_rng(7)
    t = np.arange(3000) * 0.01
    v = rng.standard_normal(t.size)
    v0 = v - v.mean()
    s = loop._harmonic_shares(t, v, float(v0 @ v0), 0.0, 5)
    np.testing.assert_allclose(s, _shares_by_definition(t, v, 0.0, 5), atol=1e-10)
    np.testing.assert_allclose(s, 0.0, atol=1e-10)
