"""The bristle state moves only with motion the record resolves (issue 7, docs/calibration.md
"Session 22").

``fit.resolved_direction`` is a zig-zag filter: a turning point counts as a reversal only once the
position has come back by ``h`` from it. The pre-sliding candidate drives its bristle state with
the velocity only where it agrees with that direction, so a wiggle of a few encoder counts —
the velocity loop hunting on quantised counts — does not flip it.

The filter is checked against hand-worked sequences and, with hypothesis, against properties
written from its definition alone (every reported reversal has an excursion of at least ``h``,
every stretch moves the way it is labelled); the state on a ramp with a sub-resolution wiggle
against the same ramp without it; the loop on a record of the independent generator.
"""
from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from plant.calibration.bench_records import make_record
from plant.calibration.fit import (MIN_TRANSITION_COUNTS, ModelSpec, design_full, prepare, presliding_state,
                                   resolved_direction)
from plant.calibration.io import load_record


def test_hand_worked_sequences():
    q = np.array([0, 1, 2, 3, 2.5, 3.5, 5, 6, 4, 3, 2, 2.2, 1, 0.5, 2, 4.0])
    # the dip 3 → 2.5 and the bump 2 → 2.2 are under h = 1; the top 6 and the bottom 0.5 are reversals
    np.testing.assert_array_equal(resolved_direction(q, 1.0),
                                  [1, 1, 1, 1, 1, 1, 1, 1, -1, -1, -1, -1, -1, -1, 1, 1])
    # h = 0: every turning point is a reversal (the turning point belongs to the stretch it ends)
    np.testing.assert_array_equal(resolved_direction(q, 0.0),
                                  [1, 1, 1, 1, -1, 1, 1, 1, -1, -1, -1, 1, -1, -1, 1, 1])
    # before the first move of h the direction is unknown: 0
    np.testing.assert_array_equal(resolved_direction(np.array([0, 0.2, -0.3, 0.1, -2, -3, -1]), 1.0),
                                  [0, -1, -1, -1, -1, -1, 1])
    assert resolved_direction(np.array([0.0, 0.3, 0.1, 0.4]), 1.0).tolist() == [0, 0, 0, 0]


@settings(max_examples=300, deadline=None)
@given(steps=st.lists(st.integers(-3, 3), min_size=2, max_size=300), h=st.integers(1, 8))
def test_properties_from_the_definition(steps, h):
    q = np.cumsum(np.array(steps, dtype=float))
    d = resolved_direction(q, float(h))
    assert set(np.unique(d).tolist()) <= {-1.0, 0.0, 1.0}
    nz = np.flatnonzero(d != 0)
    if not nz.size:
        assert np.ptp(q) < h                     # nothing resolved: the position never spans h
        return
    assert np.all(d[nz[0]:] != 0)                # zeros only before the first resolved move
    # stretches of one label, as (first, last) sample indices
    change = (np.flatnonzero(np.diff(d[nz[0]:]) != 0) + nz[0]).tolist()
    firsts = [nz[0]] + [i + 1 for i in change]
    lasts = change + [q.size - 1]
    for k, (a, b) in enumerate(zip(firsts, lasts)):
        sgn = d[a]
        seg = q[a:b + 1]
        if k + 1 < len(firsts):
            # a stretch ends at its turning point, the extreme of the stretch and of the next one ...
            assert (seg[-1] >= seg.max()) if sgn > 0 else (seg[-1] <= seg.min())
            nxt = q[firsts[k + 1]:lasts[k + 1] + 1]
            assert (seg[-1] >= nxt.max()) if sgn > 0 else (seg[-1] <= nxt.min())
            # ... and the position comes back from it by at least h: a resolved reversal
            assert (seg[-1] - nxt.min() >= h) if sgn > 0 else (nxt.max() - seg[-1] >= h)
        # a wiggle inside a stretch never comes back by h from the stretch's running extreme
        run = np.maximum.accumulate(seg) if sgn > 0 else np.minimum.accumulate(seg)
        assert np.all(np.abs(run - seg) < h)


def test_sub_resolution_wiggle_leaves_the_bristle_state_alone():
    res = 1e-7                                   # one position quantum [rad]
    dt = 1e-3
    t = np.arange(4000) * dt
    q = 2e-5 * t                                 # 20 µrad/s, one direction
    sel = (t > 1.0) & (t < 1.02)
    q[sel] -= 5 * res * np.sin(np.pi * (t[sel] - 1.0) / 0.02) ** 2   # 5 quanta back, then on
    w = np.gradient(q, dt)
    assert (w < 0).any()                         # the wiggle does reverse the velocity
    d = resolved_direction(q, MIN_TRANSITION_COUNTS * res)
    assert np.all(d[d != 0] == 1)
    k = 1.0 / (20 * res)                         # pre-sliding displacement 20 quanta
    s_raw = presliding_state(w, k, dt)
    s_res = presliding_state(np.where(w * d > 0, w, 0.0), k, dt)
    assert s_raw[t > 0.5].min() < 0.9            # driven by the raw velocity the state swings back
    assert s_res[t > 0.5].min() > 0.999          # driven by the resolved motion it stays at +1


def test_loop_uses_the_resolved_state(tmp_path):
    """On a record of the independent generator the loop's pre-sliding column is the state driven by
    the resolved motion (design_full), not by the raw velocity."""
    r = make_record(3005)
    path = tmp_path / "rec.csv"
    r.write_csv(path)
    prep = prepare(load_record(path))
    k = 1.0 / (30 * prep.position_resolution)
    names, X = design_full(prep, ModelSpec(presliding_k=k))
    c = X[:, names.index("coulomb")]
    h = MIN_TRANSITION_COUNTS * prep.position_resolution
    d = resolved_direction(prep.q, h)
    expected = presliding_state(np.where(prep.dq * d > 0, prep.dq, 0.0), k, prep.dt_s)
    np.testing.assert_allclose(c, expected)
    raw = presliding_state(prep.dq, k, prep.dt_s)
    assert np.abs(raw - expected).max() > 0.1    # the record has wiggles the change ignores
