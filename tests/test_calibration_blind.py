"""The calibration loop on the blind generator (issue 7; docs/calibration.md, "Session 24").

``plant/calibration/blind_records.py`` was written without reading the loop, so its records test
whether the loop's decisions transfer to drives it was not built around. On blind seeds 0–59 and
100–159 they do not: 33/60 exact sets each. This module runs a small subset chosen by a rule (the
first seed of each hidden category in the plan: every library kind alone, clean, every
out-of-library effect), asserts what holds there, and asserts the issue's targets on it: a strict
expected failure until session 58, met on the subset since (10 of 11 exact; never-used blind records
stay below them).
"""

from __future__ import annotations

import json

import pytest

from plant.calibration import blind_records as blind


def _first_seed_of_each_category() -> list[int]:
    """The first seed in 0–59 of each single-kind, clean and out-of-library hidden set."""
    seen: dict[tuple[str, ...], int] = {}
    hidden = blind.plan()
    for s in blind.BLIND_SEEDS:
        h = tuple(hidden[s % len(hidden)])
        if len(h) <= 1:
            seen.setdefault(h, s)
    return sorted(seen.values())


BLIND_CI_SEEDS = _first_seed_of_each_category()


def test_subset_rule_covers_every_category():
    """One record per library kind, one clean, one per out-of-library effect."""
    hidden = [tuple(blind.plan()[s % 60]) for s in BLIND_CI_SEEDS]
    assert () in hidden
    assert {h[0] for h in hidden if h} == set(blind.LIBRARY_KINDS) | set(blind.OUT_OF_LIBRARY)


@pytest.fixture(scope="module")
def blind_benchmark(tmp_path_factory):
    from host.calibration_benchmark import run_benchmark

    out = tmp_path_factory.mktemp("blind")
    run_benchmark(out, BLIND_CI_SEEDS, progress=lambda line: None, generator_name="blind")
    return out, json.loads((out / "benchmark.json").read_text())


def test_blind_benchmark_runs_and_scores_its_own_out_of_library_names(blind_benchmark):
    """Every record calibrates; the confusion matrix has the blind generator's out-of-library rows;
    the output names the generator."""
    out, res = blind_benchmark
    s = res["summary"]
    assert s["failures"] == []
    assert res["generator"] == "blind"
    for name in blind.OUT_OF_LIBRARY:
        assert name in s["confusion"]["rows"]
    assert s["out_of_library"]["n"] == len(blind.OUT_OF_LIBRARY)
    assert "blind" in (out / "benchmark.md").read_text().splitlines()[0]


def test_blind_named_periods_and_frequencies_are_right(blind_benchmark):
    """What held on all 120 blind records: a ripple's period and a line's frequency, when that kind
    is named right, are within issue 7's 3 %."""
    _, res = blind_benchmark
    k = res["summary"]["key_parameters"]
    named = 0
    for name in ("position_periodic.period_rad", "time_periodic.frequency_hz"):
        if k[name]["n"]:
            named += 1
            assert k[name]["within_tolerance"] == k[name]["n"], (name, k[name])
    assert named == 2       # both kinds are named right on this subset


def test_blind_targets_on_subset(blind_benchmark):
    """Issue 7's targets on the blind subset: exact set ≥ 90 %, no invention on clean records,
    out-of-library records without a library kind ≥ 90 %.

    A strict expected failure until session 58 (session 24: extra lines or terms on 0, 2, 4 and 34,
    backlash missed on 12, the load-dependent friction of 3 forced into a time line). Since session 58
    the subset meets them, 10 of 11: the last wrong record there, compliant mode 34, was named
    asymmetric friction whose split put a direction's friction level at its bound 0, which the
    ``friction_bound`` rule (decided on never-used records) now refuses; backlash 12 (2 reversals)
    is still missed. On never-used blind records the targets are not met (docs/calibration.md,
    "Session 58"), so this is a regression test of the subset, not the issue's answer."""
    _, res = blind_benchmark
    s = res["summary"]
    bad = [(r["seed"], r["hidden"], r["named"]) for r in res["records"] if not r["exact"]]
    assert s["exact_set_accuracy"] >= 0.90, bad
    assert s["clean"]["false_positive_seeds"] == []
    assert s["out_of_library"]["ok_fraction"] >= 0.90


def test_score_takes_the_generators_out_of_library_names():
    """A hidden name outside the library counts as out-of-library only when the generator says so."""
    from host.calibration_benchmark import score

    recs = [{"seed": 1, "hidden": ["torque_delay"], "named": [], "unexplained": [], "undecided": []},
            {"seed": 2, "hidden": ["torque_delay"], "named": ["time_periodic"], "unexplained": [], "undecided": []}]
    s = score(recs, ("torque_delay",))
    assert s["out_of_library"] == {"n": 2, "ok": 1, "ok_fraction": 0.5, "with_unexplained_entry": 0}
    assert s["confusion"]["counts"]["torque_delay"]["time_periodic"] == 1
