"""A periodic residual just above the two-cycle limit is a spectral peak (session 27, issue 7).

Blind record 117 hid a position ripple of 2.12 cycles over the travel that held 97 % of the
residual; the spectrum's grid started at 2 cycles, its share was largest at the first grid point,
and an end point is never a local maximum, so the ripple was never a candidate. The signals here
are written from the equations in the test, not by the project's generators.

The time spectrum keeps its grid from two cycles over the record: a time line of about two cycles
on a motion with few reversals is a slow function of the position too, and it took the place of a
load-dependent friction on blind record 55 (docs/calibration.md, "Session 27").
"""

import numpy as np
import pytest

from plant.calibration import residuals as res


def _ramp_position(n: int, span: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Back-and-forth constant-speed legs over ``span``: position [rad], velocity [rad/s] (1 s legs)."""
    t = np.arange(n) * 0.01
    phase = (t % 2.0) / 2.0
    q = span * np.where(phase < 0.5, 2 * phase, 2 - 2 * phase)
    dq = np.gradient(q, t)
    return q, dq


@pytest.mark.parametrize("cycles", [2.05, 2.12, 2.3])
def test_position_peak_just_above_two_cycles_is_found(cycles):
    rng = np.random.default_rng(117)
    span = 0.0839
    q, dq = _ramp_position(20000, span, rng)
    period = span / cycles
    r = 2.8 * np.sin(2 * np.pi * q / period + 0.7) + 0.3 * rng.standard_normal(q.size)
    peaks = res.find_peaks(res.position_spectrum(q, dq, r), n_peaks=3)
    assert peaks, "no peak at all"
    best = peaks[0]
    span_moving = np.ptp(q[res.moving_mask(dq)])
    # a periodogram resolves 1/span; the candidate's fit refines the period from there
    assert abs(best["frequency"] - 1.0 / period) <= 0.5 / span_moving
    assert best["share"] > 0.9


def test_a_maximum_below_two_cycles_is_not_reported_at_the_edge():
    """1.4 cycles: the rule refuses it, and the spectrum's falling flank at 2 cycles is no peak."""
    rng = np.random.default_rng(3)
    span = 0.5
    q, dq = _ramp_position(20000, span, rng)
    r = np.sin(2 * np.pi * q * 1.4 / span) + 0.05 * rng.standard_normal(q.size)
    spec = res.position_spectrum(q, dq, r)
    assert spec["f_min"] == pytest.approx(res.MIN_CYCLES / np.ptp(q[res.moving_mask(dq)]))
    for p in res.find_peaks(spec, n_peaks=5):
        assert p["frequency"] >= spec["f_min"]
        assert abs(p["frequency"] * span - 2.0) > 0.1, "the edge of the range reported as a peak"
