"""The calibration benchmark: an independent generator, and the loop scored on a fixed subset of it.

The CI subset (:data:`plant.calibration.bench_records.CI_SEEDS`, fixed before the loop was
changed) holds two clean records, every library kind alone, a pair and two out-of-library
records. The targets asserted are the issue's, on that subset: exact set ≥ 90 %, no effect on
clean records, no library kind named on out-of-library records, key parameters within 3 %
(period, frequency) and 30 % (amplitudes, backlash width, asymmetric viscous coefficients).
"""

import ast
import json
from pathlib import Path

import numpy as np
import pytest

import plant.calibration.bench_records as bench_records
from plant.calibration.bench_records import CI_SEEDS, LIBRARY_KINDS, OUT_OF_LIBRARY, make_record, plan
from plant.effects import EFFECT_KINDS

ALLOWED_IMPORTS = {"__future__", "math", "dataclasses", "numpy", "numba"}


def test_generator_imports_nothing_from_plant():
    """The independent generator imports only math, dataclasses, numpy and numba — nothing of plant/."""
    tree = ast.parse(Path(bench_records.__file__).read_text())
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, "relative import in the independent generator"
            found.add(node.module.split(".")[0])
    assert found <= ALLOWED_IMPORTS, found
    assert "plant" not in found


def test_generator_kinds_match_registry_and_plan_covers_them():
    """The generator's kind names equal the plant.effects registry; the plan has ≥ 60 records with
    every kind alone, pairs, clean records and every out-of-library effect."""
    assert set(LIBRARY_KINDS) == set(EFFECT_KINDS)
    p = plan()
    assert len(p) >= 60
    for k in LIBRARY_KINDS:
        assert (k,) in p
    assert any(len(h) == 2 for h in p)
    assert p.count(()) >= 5
    for k in OUT_OF_LIBRARY:
        assert (k,) in p


def test_generator_measurement_chain():
    """Records are quantised positions, uniformly sampled at 200 Hz–1 kHz, with velocity from
    differenced counts, reproducible from the seed."""
    a, b = make_record(3), make_record(3)
    assert np.array_equal(a.torque_nm, b.torque_nm)
    res = a.meta["resolution_rad"]
    counts = a.position_rad / res
    assert np.allclose(counts, np.round(counts), atol=1e-6)
    dt = np.diff(a.t_s)
    assert np.allclose(dt, dt[0]) and 200 <= 1 / dt[0] <= 1000 + 1e-6
    assert np.allclose(a.velocity_rad_s[1:], np.diff(a.position_rad) / dt[0])


@pytest.fixture(scope="module")
def ci_benchmark(tmp_path_factory):
    from host.calibration_benchmark import run_benchmark

    out = tmp_path_factory.mktemp("bench")
    run_benchmark(out, CI_SEEDS, progress=lambda line: None)
    return out, json.loads((out / "benchmark.json").read_text())


def test_benchmark_writes_its_figures(ci_benchmark):
    """benchmark.json/benchmark.md carry the confusion matrix, accuracy, false positives, key
    parameters and time/memory per record."""
    out, res = ci_benchmark
    s = res["summary"]
    for key in ("exact_set_accuracy", "confusion", "clean", "out_of_library", "key_parameters", "time", "memory"):
        assert key in s
    assert s["failures"] == []
    for r in res["records"]:
        assert r["wall_s"] > 0 and r["peak_rss_mb"] > 0
        assert isinstance(r["undecided"], list)
    assert "missed_reported_undecided" in s
    assert "Confusion matrix" in (out / "benchmark.md").read_text()
    assert "per_kind" in s and "Per kind" in (out / "benchmark.md").read_text()
    assert s["limits"]["nameable"] <= s["n_records"] and "what the records allow" in (out / "benchmark.md").read_text()
    assert all("motion" in r and "miss_class" in r for r in res["records"])


def test_benchmark_no_invention_on_ci_subset(ci_benchmark):
    """On the CI subset no effect is invented on clean records and no library kind is named on the
    out-of-library records (issue 7 targets: 0 false positives; ≥ 90 % of out-of-library records)."""
    _, res = ci_benchmark
    s = res["summary"]
    assert s["clean"]["n"] >= 2 and s["clean"]["false_positive_seeds"] == []
    assert s["out_of_library"]["n"] >= 2 and s["out_of_library"]["ok_fraction"] >= 0.90


def test_benchmark_targets_on_ci_subset(ci_benchmark):
    """The issue's exact-set and key-parameter targets on the fixed CI subset. A strict expected
    failure until session 35 (10 of 11 exact since session 18; seed 4's backlash width was the lost
    motion, 47 % off). Since session 35 the width of a backlash inside a declared spring whose mode
    lies above the fit's band is the gap (seed 4: 7 % off); seed 3's barely excited pre-sliding is
    still the one miss (10 of 11 = 90.9 %)."""
    _, res = ci_benchmark
    s = res["summary"]
    bad = [(r["seed"], r["hidden"], r["named"]) for r in res["records"] if not r["exact"]]
    assert s["exact_set_accuracy"] >= 0.90, bad
    for name, k in s["key_parameters"].items():
        if k["n"] and k["tolerance"] is not None:
            assert k["within_tolerance"] == k["n"], (name, k)


def test_backlash_gap_on_ci_subset(ci_benchmark):
    """The backlash gap the report gives with the drive's stiffness declared (refitted inside the
    declared spring, session 32) is within the issue's 30 % on every CI record where backlash is named."""
    _, res = ci_benchmark
    k = res["summary"]["key_parameters"]["backlash.gap_rad"]
    assert k["n"] >= 1 and k["within_tolerance"] == k["n"], k


def test_score_counts_misses_the_record_could_not_decide():
    """A record is listed as 'wrong only by undecided effects' when every missed kind is in its
    ``undecided`` list and nothing extra was named; it stays wrong in the exact-set figure."""
    from host.calibration_benchmark import score

    und = [{"kind": "presliding", "cv_gain_pct": 8.0, "n_reversals": 3, "min_reversals": 13}]
    recs = [
        {"seed": 1, "hidden": ["presliding"], "named": [], "unexplained": [], "undecided": und},          # counted
        {"seed": 2, "hidden": ["presliding"], "named": ["gravity_imbalance"], "unexplained": [], "undecided": und},  # extra kind
        {"seed": 3, "hidden": ["backlash"], "named": [], "unexplained": [], "undecided": und},            # other kind undecided
        {"seed": 4, "hidden": ["presliding", "position_periodic"], "named": ["position_periodic"], "unexplained": [],
         "undecided": und},                                                                               # counted
        {"seed": 5, "hidden": [], "named": [], "unexplained": [], "undecided": []},                      # right
    ]
    s = score(recs)
    assert s["missed_reported_undecided"] == {"n": 2, "seeds": [1, 4]}
    assert s["n_exact"] == 1


def test_score_per_kind_named_and_hidden():
    """Per kind: of the records naming it, how many hide it; of those hiding it, how many name it;
    and the seeds that name it where it is not hidden (session 41). Counted by hand below."""
    from host.calibration_benchmark import score

    recs = [
        {"seed": 1, "hidden": ["presliding"], "named": ["presliding"], "unexplained": [], "undecided": []},
        {"seed": 2, "hidden": ["delay"], "named": ["presliding"], "unexplained": [], "undecided": []},
        {"seed": 3, "hidden": [], "named": ["presliding", "time_periodic"], "unexplained": [], "undecided": []},
        {"seed": 4, "hidden": ["presliding", "backlash"], "named": ["backlash"], "unexplained": [], "undecided": []},
        {"seed": 5, "hidden": ["time_periodic"], "named": [], "unexplained": [], "undecided": []},
    ]
    k = score(recs)["per_kind"]
    assert (k["presliding"]["named"], k["presliding"]["named_and_hidden"], k["presliding"]["wrongly_named_seeds"]) == (3, 1, [2, 3])
    assert (k["presliding"]["hidden"], k["presliding"]["hidden_and_named"]) == (2, 1)
    assert k["presliding"]["named_right_fraction"] == 1 / 3 and k["presliding"]["found_fraction"] == 0.5
    assert (k["time_periodic"]["named"], k["time_periodic"]["named_and_hidden"], k["time_periodic"]["hidden"]) == (1, 0, 1)
    assert k["time_periodic"]["named_right_fraction"] == 0.0 and k["time_periodic"]["found_fraction"] == 0.0
    assert (k["backlash"]["named_right_fraction"], k["backlash"]["found_fraction"]) == (1.0, 1.0)
    assert k["gravity_imbalance"]["named_right_fraction"] is None and k["gravity_imbalance"]["found_fraction"] is None


def test_record_motion_counts_trajectory_reversals_not_overshoot():
    """Reversals are sign changes between runs of one sign at least MIN_RUN_S long: a servo's 0.1 s
    overshoot at a stop is not one, a slow stair (1e-3 of the peak speed) still is. Written here:
    +0.1 rad/s 2 s, −0.002 rad/s 0.1 s (overshoot), 0 for 1 s, +1e-4 rad/s 2 s (slow stair), −0.05 rad/s 2 s."""
    from types import SimpleNamespace

    from host.calibration_benchmark import record_motion

    dt = 1e-3
    v = np.concatenate([np.full(2000, 0.1), np.full(100, -0.002), np.zeros(1000), np.full(2000, 1e-4), np.full(2000, -0.05)])
    rec = SimpleNamespace(t_s=np.arange(v.size) * dt, velocity_rad_s=v, meta={}, hidden=(), truth={})
    assert record_motion(rec) == {"n_reversals": 1, "one_way": False, "gap_over_windup": None}
    rec1 = SimpleNamespace(t_s=np.arange(4000) * dt, velocity_rad_s=np.full(4000, 0.1), meta={}, hidden=(), truth={})
    assert record_motion(rec1)["one_way"] and record_motion(rec1)["n_reversals"] == 0
    # the blind generator's own count; a two-mass backlash: gap over the wind-up 2Fc/K
    rec2 = SimpleNamespace(meta={"n_reversals": 4, "two_mass": {"stiffness_nm_rad": 4000.0}, "coulomb_nm": 5.0},
                           hidden=("backlash",), truth={"backlash": {"width_rad": 1e-4}})
    m = record_motion(rec2)
    assert m["n_reversals"] == 4 and not m["one_way"] and m["gap_over_windup"] == pytest.approx(1e-4 / (2 * 5.0 / 4000.0))


def test_score_classes_misses_by_what_the_records_allow():
    """Classes by hand (A not in the motion, B gap under the wind-up, C too few reversals, D other,
    E named and not hidden) and the two ceilings."""
    from host.calibration_benchmark import MIN_REVERSALS, score

    def rec(seed, hidden, named, n_rev=20, one_way=False, gap=None):
        return {"seed": seed, "hidden": hidden, "named": named, "unexplained": [], "undecided": [],
                "motion": {"n_reversals": n_rev, "one_way": one_way, "gap_over_windup": gap}}

    recs = [
        rec(1, ["asymmetric_friction"], [], n_rev=0, one_way=True),       # A
        rec(2, ["backlash"], [], gap=0.01),                              # B
        rec(3, ["presliding"], [], n_rev=MIN_REVERSALS - 1),             # C
        rec(4, ["presliding"], [], n_rev=MIN_REVERSALS),                 # D: enough reversals
        rec(5, [], ["presliding"]),                                      # E
        rec(6, ["presliding"], ["backlash"], n_rev=3),                   # C and E
        rec(7, ["gravity_imbalance"], ["gravity_imbalance"]),            # exact
        rec(8, ["backlash"], [], n_rev=0, gap=0.01),                     # A before B
    ]
    s = score(recs)
    assert [r["miss_class"] for r in recs] == ["A", "B", "C", "D", "E", "CE", "", "A"]
    lim = s["limits"]
    assert lim["classes"]["A"] == {"n": 2, "seeds": [1, 8]} and lim["classes"]["CE"]["seeds"] == [6]
    assert lim["nameable"] == 8 - 3 and lim["nameable_at_rule_level"] == 8 - 5
    assert s["n_exact"] == 1
    # records without their motion: no limits (a run before session 41)
    assert score([{k: v for k, v in r.items() if k != "motion"} for r in recs])["limits"] is None
