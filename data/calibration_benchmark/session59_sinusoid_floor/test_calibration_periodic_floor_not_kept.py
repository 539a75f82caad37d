"""The phase guard's fundamental on a sinusoid of fewer than 3 cycles (issue 7, session 59).

``loop.periodic_motion`` searches fundamentals with at least 3 cycles in the record first, and a sinusoid
of 2–3 cycles (3 harmonics) only when that finds none. On a sinusoid of 2.5–2.9 cycles the first search's
best fundamental was the lowest frequency it may try — held at its limit, 5 % off the motion's and still
explaining 95 % of the velocity — so the guard's lines drifted against the motion over the record (used
blind 27045, a clean record, named gravity). Now, where the first search's fundamental is held at its
limit, the sinusoid search is asked too. The velocities are written in the test (a sinusoidal position
with measurement noise), not produced by the project's generators; the decision on never-used records is
in ``data/calibration_benchmark/session59_sinusoid_floor/`` and docs/calibration.md, "Session 59".
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from plant.calibration import loop

FS_HZ = 100.0


def sinusoid_rows(cycles: float, duration_s: float, seed: int):
    """Rows as ``loop._velocity_rows`` reads them: ``theta = A·(1 − cos 2πft)`` started at rest (the
    blind generator's sinusoid, written again here), its velocity with 1 % white noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration_s, 1.0 / FS_HZ)
    f = cycles / duration_s
    amp = rng.uniform(0.2, 1.0)
    w = 2 * np.pi * f
    dq = amp * w * np.sin(w * t)
    dq = dq + 0.01 * amp * w * rng.standard_normal(t.size)
    return SimpleNamespace(t=t, dq=dq, decim=1, dt_s=1.0 / FS_HZ), f


@pytest.mark.parametrize("cycles, duration_s", [(2.78, 130.8), (2.55, 60.0), (2.9, 200.0), (2.62, 95.0)])
def test_a_sinusoid_of_fewer_than_three_cycles_gets_its_own_fundamental(cycles, duration_s):
    prep, f = sinusoid_rows(cycles, duration_s, seed=int(100 * cycles))
    f_found, share, k = loop.periodic_motion(prep)
    assert f_found is not None and k == loop.PHASE_HARMONICS
    # within a tenth of the record's frequency bin (1/T) of the motion's: the guard's phase then drifts by
    # less than 0.63 rad over the record (main: the first search's limit, 2.91 cycles — up to 0.36 bins off)
    assert abs(f_found - f) * duration_s < 0.1, (f_found, f)
    assert share > 0.99


@pytest.mark.parametrize("cycles", [3.5, 6.3, 12.0])
def test_with_three_cycles_or_more_the_first_search_stands(cycles):
    # the sinusoid search is not asked where the first search's fundamental is inside its range: a
    # sub-harmonic (f/2 explains all that f does on a sinusoid of ≥ 6 cycles) never replaces it by noise
    prep, f = sinusoid_rows(cycles, 100.0, seed=int(10 * cycles))
    f_found, _, _ = loop.periodic_motion(prep)
    assert f_found is not None and abs(f_found / f - 1.0) < 0.01, (f_found, f)
