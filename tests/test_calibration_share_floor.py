"""A named effect must predict at least the share of the held-out error the report speaks of
(issue 7, session 51).

The rank test (``loop.cv_compare``) asks whether a candidate predicts better on every part of a
record, not by how much. On records of tens of thousands of samples whose friction is not the
model's (LuGre with bristles against a static curve), a line or a friction split that takes 0.1 % of
the held-out error takes it in every batch and passes at any level. Blind records 20531 and 20487
(clean, written by the blind generator of session 24) were named two time lines and an asymmetric
friction that way. ``loop._below_share_floor`` now refuses a library candidate under
``LoopConfig.min_share_pct`` (3 %, the share from which ``unexplained`` lists structure) with that
reason. Decided on never-used seeds: ``data/calibration_benchmark/session51_share_floor/``.
"""
from __future__ import annotations

import dataclasses

import pytest

from plant.calibration import loop
from plant.calibration.blind_records import make_record as make_blind
from plant.calibration.report import calibrate


def test_the_floor_refuses_under_min_share_and_says_why():
    cfg = loop.LoopConfig()
    assert cfg.min_share_pct == 3.0
    assert loop._below_share_floor({"cv_gain_pct": 3.0, "cv_z": 5.5}, cfg) is None
    why = loop._below_share_floor({"cv_gain_pct": 0.14, "cv_z": 5.4}, cfg)
    assert why is not None and "0.14 %" in why and "z = 5.4" in why and "under 3 %" in why
    # one constant for both floors: lowering it lowers both
    low = dataclasses.replace(cfg, min_share_pct=0.1)
    assert loop._below_share_floor({"cv_gain_pct": 0.14, "cv_z": 5.4}, low) is None


@pytest.mark.parametrize("seed, sliver", [(20531, "time_periodic"), (20487, "asymmetric_friction")])
def test_clean_blind_record_names_no_sliver(seed, sliver, monkeypatch, tmp_path):
    """A clean blind record: nothing is named, and the kind the rank test alone would name is in
    ``rejected`` with the floor's reason. With the floor patched out (main before session 51) that
    kind is named, so the check can fail."""
    rec = make_blind(seed)
    assert rec.hidden == ()
    rec.write_csv(tmp_path / "r.csv")
    rep = calibrate(tmp_path / "r.csv", tmp_path / "out", plots=False)
    assert [e["kind"] for e in rep["effects"]] == []
    floored = [r for r in rep["rejected"] if "of the held-out error" in r["reason"]]
    assert any(r["kind"] == sliver and 0 < r["cv_gain_pct"] < 3.0 for r in floored)
    monkeypatch.setattr(loop, "_below_share_floor", lambda c, cfg: None)
    rep2 = calibrate(tmp_path / "r.csv", tmp_path / "out2", plots=False)
    named = [e for e in rep2["effects"] if e["kind"] == sliver]
    assert named and all(e["cv_gain_pct"] < 3.0 for e in named)


def test_one_constant_moves_the_unexplained_floor_too(tmp_path):
    """``_unexplained`` lists spectral structure from ``cfg.min_share_pct`` of the final residual, the same
    constant as the named-effect floor (session 51's "one constant for both floors", checked there only for
    the named effects). Fixed seed 46 of the independent generator (clean) leaves two time peaks of
    4.5 % and 3.3 % in ``unexplained`` (``benchmark.json``): raised to 4 %, the floor keeps the first only;
    raised to 5 %, neither."""
    from plant.calibration.bench_records import make_record
    from plant.calibration.fit import prepare
    from plant.calibration.io import load_record

    rec = make_record(46)
    rec.write_csv(tmp_path / "r.csv")
    prep = prepare(load_record(tmp_path / "r.csv"))
    cfg = loop.LoopConfig()
    res = loop.run_loop(prep, cfg=cfg)
    alias = loop.constant_speed_runs(prep)

    def time_shares(c):
        return sorted(u["share_pct"] for u in loop._unexplained(prep, res.final, c, res.linear, res.out_of_library, alias)
                      if u["domain"] == "time" and u.get("kind") is None)

    base = time_shares(cfg)
    assert len(base) == 2 and 3.0 <= base[0] < 4.0 <= base[1] < 5.0, base
    assert time_shares(dataclasses.replace(cfg, min_share_pct=4.0)) == pytest.approx(base[1:], rel=0.05)
    assert time_shares(dataclasses.replace(cfg, min_share_pct=5.0)) == []
