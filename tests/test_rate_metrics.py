"""Per-tick / 10 ms rate errors and forced-line detection (host/rate_metrics.py), on synthetic counts."""

from __future__ import annotations

import math

import numpy as np
import pytest

from host.rate_metrics import classify_oscillation, match_gear_line, rate_metrics, spectral_lines, tick_metrics
ARCSEC_PER_COUNT = 1_296_000.0 / (4_608_000 * 24.5)  # paper §3.2 encoder through the 1:24.5 roller (test-local: independent of the code)


def _counts(rate_fn, t):
    """Cumulative QEI counts (floor) of the integral of rate_fn, computed on a 0.1 ms grid."""
    tf = np.arange(0.0, t[-1] + 1e-4, 1e-4)
    pos = np.concatenate([[0.0], np.cumsum(rate_fn(tf[:-1] + 5e-5) * 1e-4)])
    return np.floor(np.interp(t, tf, pos) / ARCSEC_PER_COUNT)


def test_tick_quantisation_at_sidereal():
    """At 15″/s a 5 ms tick holds 6.53 counts: readings of 6 and 7 counts are −8.2 % and +7.1 %."""
    one = ARCSEC_PER_COUNT / 0.005
    assert 15.0 * 0.005 / ARCSEC_PER_COUNT == pytest.approx(6.533, abs=1e-3)
    m = tick_metrics(np.array([6, 7, 7, 6]) * one, 15.0)
    assert m["peak_error_tick_pct"] == pytest.approx(8.2, abs=0.05)
    m = tick_metrics(np.array([6, 7, 8]) * one, 15.0)
    assert m["peak_error_tick_pct"] == pytest.approx(22.4, abs=0.05)
    assert m["rms_error_tick_pct"] == pytest.approx(math.sqrt(sum(((c * one - 15) / 15 * 100) ** 2 for c in (6, 7, 8)) / 3),
                                                    abs=1e-3)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_forced_mesh_line_found_and_named(seed):
    """A 4.5 Hz ripple on 600″/s is found at its frequency and amplitude and named the stage-1 mesh."""
    rng = np.random.default_rng(seed)
    amp = rng.uniform(2.0, 6.0)                     # % of setpoint
    f = 9733.19 * 600 / 1_296_000
    ph = rng.uniform(0, 2 * math.pi)
    t = np.arange(0, 15.0, 0.01)
    counts = _counts(lambda x: 600.0 * (1 + amp / 100 * np.sin(2 * math.pi * f * x + ph)), t)
    m = rate_metrics(t, counts, None, 600.0, ARCSEC_PER_COUNT)
    top = m["disturbance_lines"][0]
    assert top["frequency_hz"] == pytest.approx(f, abs=0.05)
    assert top["amplitude_pct"] == pytest.approx(amp, rel=0.1)
    assert top["gear_line"]["line"] == "stage1_mesh"
    # the 10 ms reading sees the ripple (plus quantisation), not the 100 ms smoothing
    assert amp * 0.9 < m["peak_error_10ms_pct"] < amp + 0.5
    # a 100 ms detector "limit cycle" at the line's period is a forced line
    lc, forced = classify_oscillation(True, 1.0 / f, m["disturbance_lines"])
    assert lc is False and forced["gear_line"]["line"] == "stage1_mesh"


def test_unmatched_oscillation_stays_a_limit_cycle():
    """An oscillation at no gear order (1.7 Hz at 100″/s) stays a limit cycle."""
    t = np.arange(0, 20.0, 0.01)
    counts = _counts(lambda x: 100.0 * (1 + 0.3 * np.sin(2 * math.pi * 1.7 * x)), t)
    m = rate_metrics(t, counts, None, 100.0, ARCSEC_PER_COUNT)
    assert m["disturbance_lines"][0]["frequency_hz"] == pytest.approx(1.7, abs=0.05)
    assert m["disturbance_lines"][0]["gear_line"] is None
    assert classify_oscillation(True, 1 / 1.7, m["disturbance_lines"]) == (True, None)


def test_no_lines_in_a_steady_rate():
    t = np.arange(0, 10.0, 0.01)
    counts = _counts(lambda x: 600.0 + 0 * x, t)
    assert spectral_lines(np.diff(counts) * ARCSEC_PER_COUNT / 0.01 / 6 - 100, 0.01) == []


def test_match_gear_line_tolerance():
    assert match_gear_line(0.056, 100.0, 60.0)["line"] == "motor_twice"
    assert match_gear_line(3.0, 600.0, 15.0) is None
