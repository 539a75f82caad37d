"""The Coulomb column ramps across rests (issue 7, session 13; docs/calibration.md "Baseline").

At a reversal a servo-driven axis sticks while its loop ramps the torque through the static band;
``sign`` of the noise-level velocity there flips from sample to sample, and the decimation filter
spread that ±Fc error as ringing into the moving samples beside the rest, where reversal effects
took it as evidence. :func:`plant.calibration.fit.stick_ramp` replaces each rest run by a straight
line between the sliding values around it.
"""

import math

import numpy as np
import pytest

from plant.calibration import fit, loop
from plant.calibration.bench_records import make_record
from plant.calibration.io import load_record
from plant.calibration.loop import run_loop


def _reference_ramp(c, rest):
    """Sample by sample, written apart from stick_ramp: the nearest sliding sample on each side
    and the linear interpolation between them by index distance."""
    n = len(c)
    out = [float(x) for x in c]
    for i in range(n):
        if not rest[i]:
            continue
        lo = i
        while lo >= 0 and rest[lo]:
            lo -= 1
        hi = i
        while hi < n and rest[hi]:
            hi += 1
        if lo < 0 and hi >= n:
            out[i] = 0.0
        elif lo < 0:
            out[i] = float(c[hi])
        elif hi >= n:
            out[i] = float(c[lo])
        else:
            out[i] = c[lo] + (c[hi] - c[lo]) * (i - lo) / (hi - lo)
    return np.array(out)


@pytest.mark.parametrize("seed", range(20))
def test_stick_ramp_matches_a_sample_by_sample_interpolation(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 400))
    c = rng.choice([-1.0, 0.0, 1.0], size=n)
    # runs of rest of random lengths, at the ends too
    rest = np.zeros(n, bool)
    for _ in range(int(rng.integers(0, 8))):
        a = int(rng.integers(0, n))
        rest[a:a + int(rng.integers(1, 40))] = True
    if seed == 0:
        rest[:] = True
    got = fit.stick_ramp(c, rest)
    np.testing.assert_allclose(got, _reference_ramp(c, rest), atol=1e-12)
    np.testing.assert_array_equal(got[~rest], c[~rest])     # moving samples untouched
    assert got is not c


def _named(path, **prepare_kw):
    return [e.kind for e in run_loop(fit.prepare(load_record(path), **prepare_kw)).effects()]


@pytest.mark.parametrize("seed", [1005, 1006])
def test_clean_records_whose_rest_error_rang_get_no_effect(seed, monkeypatch, tmp_path):
    """Development records 1005 and 1006 (clean; the independent generator) were named backlash and
    pre-sliding from that ringing. With the ramp nothing is named; with ``sign`` at rest (the old
    column, patched in) the effect comes back, so the check can fail. The control runs without the
    hunting rule (session 44): on 1005 a slow stair sticks and slips at 3.9–6.4 s, and leaving it out
    removes the backlash as well, so with the rule on the control could not tell the ramp's work. For
    the same reason the control runs without session 45's reversal-stick rule: on 1006 the axis sticks
    at its reversals and that rule refuses the ringing's pre-sliding as well — and without session 61's
    reversals' t-test: on 1005 (5 counted reversals) its Bonferroni over the two tests lowers the
    backlash's Stribeck re-test to z = 3.4 (needs 3.59), which then refuses the ringing's backlash too."""
    path = tmp_path / "rec.csv"
    make_record(seed).write_csv(path)        # through the CSV, as `calibrate` reads it
    assert _named(path) == []
    monkeypatch.setattr(fit, "stick_ramp", lambda c, rest: np.array(c, dtype=float))
    monkeypatch.setattr(loop, "STICK_SWING_OVER_FC", math.inf)
    monkeypatch.setattr(loop, "reversal_units", lambda prep: None)
    assert _named(path, exclude_hunting=False) != []
