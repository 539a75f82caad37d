"""Held-out samples a candidate can only extrapolate to do not count for or against it (issue 7,
session 33; docs/calibration.md "Session 33, third part").

Found on never-used seed 8255 (a tracking run): the only fast positive motion is the slew back at
the end, in the last cross-validation block; with that block held out the folds' positive motion is
at one speed, where a direction's viscous and Coulomb terms are one column, and the asymmetric
candidate's prediction there was off by 80× — a real asymmetry refused with a gain of −3774 %.
The leverage is checked against the hat matrix written out; the tracking record is written in the
test from the equations (open loop, no code of ``plant/``); 8255 comes from the independent
generator (``plant/calibration/bench_records.py``, which imports nothing from ``plant/``).
"""

import math

import numpy as np
import pytest

from plant.calibration import loop
from plant.calibration.fit import prepare
from plant.calibration.io import Record


def test_hidden_extrapolation_matches_the_hat_matrix_written_out():
    """Leverage from the explicit hat matrix X (XᵀX)⁻¹ Xᵀ (numpy's inverse, not the SVD the code uses)."""
    rng = np.random.default_rng(0)
    x = rng.uniform(0.0, 1.0, 200)
    X_tr = np.column_stack([np.ones_like(x), x, x**2])
    inv = np.linalg.inv(X_tr.T @ X_tr)
    h_max = np.max(np.einsum("ij,jk,ik->i", X_tr, inv, X_tr))
    x_te = np.array([-0.3, 0.02, 0.5, 0.97, 1.4])
    X_te = np.column_stack([np.ones_like(x_te), x_te, x_te**2])
    h_te = np.einsum("ij,jk,ik->i", X_te, inv, X_te)
    got = loop.hidden_extrapolation(X_tr, X_te)
    assert list(got) == list(h_te > h_max)
    assert got[0] and got[-1] and not got[2]


def test_a_column_the_training_rows_never_excite_is_an_extrapolation():
    X_tr = np.column_stack([np.ones(50), np.linspace(0, 1, 50), np.zeros(50)])
    X_te = np.array([[1.0, 0.5, 0.0], [1.0, 0.5, 0.3]])
    assert list(loop.hidden_extrapolation(X_tr, X_te)) == [False, True]


FS_HZ = 200.0


def _tracking_record(seed: int = 3) -> Record:
    """Rigid axis (J 2 kg·m²) with direction-dependent friction (viscous 20 / 32 N·m·s/rad, Coulomb
    1.5 / 1.2 N·m for w > 0 / w < 0), offset 0.3 N·m: a slow track at +0.05 rad/s, a slew back at
    −0.25 rad/s, a slow track at −0.05 rad/s and a slew at +0.25 rad/s at the very end, so that the
    only fast positive motion lies in the last block."""
    segs = [(0.0, 0.5), (0.05, 40.0), (-0.25, 8.0), (-0.05, 40.0), (0.25, 8.0), (0.0, 0.5)]
    v = np.concatenate([np.full(int(d * FS_HZ), lv) for lv, d in segs])
    # rate-limited to 1 rad/s²
    out, cur, dv = np.empty_like(v), 0.0, 1.0 / FS_HZ
    for i, x in enumerate(v):
        cur += min(max(x - cur, -dv), dv)
        out[i] = cur
    v = out
    t = np.arange(v.size) / FS_HZ
    q = np.cumsum(v) / FS_HZ
    a = np.gradient(v, 1.0 / FS_HZ)
    pos = v > 0
    fric = np.where(pos, 20.0 * v + 1.5 * np.tanh(v / 1e-3), 32.0 * v + 1.2 * np.tanh(v / 1e-3))
    tau = 2.0 * a + fric + 0.3 + np.random.default_rng(seed).normal(0.0, 0.03, v.size)
    cpr = 2**22 / (2 * math.pi)
    return Record(name="tracking_asymmetric", t_s=t, position=np.floor(q * cpr) / cpr, torque=tau)


def test_an_asymmetry_on_a_tracking_run_written_from_the_equations_is_still_named_within_10_percent():
    """The rule must not cost the plain case: the asymmetry is found (with or without the rule)."""
    res = loop.run_loop(prepare(_tracking_record()))
    assert [a.kind for a in res.accepted] == ["asymmetric_friction"], res.log
    p = loop.effect_from_fit(res.final, "asymmetric_friction", None).params()
    assert p["viscous_pos_nm_s_rad"] == pytest.approx(20.0, rel=0.1)
    assert p["viscous_neg_nm_s_rad"] == pytest.approx(32.0, rel=0.1)


def test_never_used_seed_8255_names_its_asymmetry_and_backlash(tmp_path):
    """The record the rule was found on (the only fast positive motion is the slew in the last
    block): main refused the asymmetry (gain −3774 %) and named nothing."""
    from plant.calibration.bench_records import make_record
    from plant.calibration.report import calibrate

    r = make_record(8255)
    path = tmp_path / "rec.csv"
    r.write_csv(path)
    rep = calibrate(str(path), str(tmp_path / "out"), plots=False,
                    gear_stiffness=r.meta["two_mass"]["stiffness_nm_rad"])
    assert sorted(e["kind"] for e in rep["effects"]) == ["asymmetric_friction", "backlash"]
    asym = next(e for e in rep["effects"] if e["kind"] == "asymmetric_friction")["params"]
    for k in ("viscous_pos_nm_s_rad", "viscous_neg_nm_s_rad"):
        assert asym[k] == pytest.approx(r.truth["asymmetric_friction"][k], rel=0.3)
