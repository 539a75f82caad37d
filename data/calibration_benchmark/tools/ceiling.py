"""Why the misses of a decision run are missed, from what the records hold (session 41).

Nothing here runs the loop: each record is generated again (same seed, same generator) and its true
motion read (:func:`host.calibration_benchmark.record_motion`); each wrong record gets the classes
of :func:`host.calibration_benchmark.miss_class` (A not in the motion, B a gap hidden by the gear's
wind-up, C a reversal kind on fewer reversals than the rule can pass, D other, E a kind named and not
hidden; :data:`host.calibration_benchmark.MISS_CLASSES`) — the same figures `benchmark-calibration`
writes, for the runner outputs of the sessions' decision runs.

Usage (repository root): python ceiling.py OUT.json RUN.json ... — writes the per-record classes and
prints the counts per generator, with the ceilings: how many records can have their exact set named
at all (no A or B miss: no rule can), and at the loop's level (no A, B or C miss; approximate: a
reversal kind that also helps away from its reversals can pass with fewer, as backlash did on
development record 1048 with 11).
"""
import collections, importlib, json, os, sys
sys.path.insert(0, os.getcwd())
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from jobs import GEN, map_jobs
from host.calibration_benchmark import generator, record_motion, score


def motion(job):
    gen, seed = job
    return gen, seed, record_motion(importlib.import_module(GEN[gen]).make_record(seed))


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    runs = [r for p in sys.argv[2:] for r in json.load(open(p))]
    ms = {(g, s): m for g, s, m in map_jobs(motion, [(r["generator"], r["seed"]) for r in runs])}
    out = []
    for gen in GEN:
        rs = [{**r, "motion": ms[(gen, r["seed"])], "undecided": [], "wall_s": None} for r in runs if r["generator"] == gen]
        if not rs:
            continue
        s = score(rs, tuple(generator(gen).OUT_OF_LIBRARY))   # the benchmark's own classes and ceilings (``limits``)
        lim, n = s["limits"], s["n_records"]
        out += [{"generator": gen, "seed": r["seed"], **r["motion"], "hidden": r["hidden"], "named": r["named"],
                 "class": r["miss_class"] or "exact"} for r in rs]
        c = collections.Counter({"exact": s["n_exact"], **{k: v["n"] for k, v in lim["classes"].items()}})
        print(f"{gen}: {n} records; " + ", ".join(f"{k} {v}" for k, v in sorted(c.items(), key=lambda x: -x[1])))
        print(f"  exact sets nameable at all (no A or B miss): {lim['nameable']}/{n} = {100 * lim['nameable'] / n:.1f} %; "
              f"at the loop's level (no A, B or C miss): {lim['nameable_at_rule_level']}/{n} = "
              f"{100 * lim['nameable_at_rule_level'] / n:.1f} %; named: {s['n_exact']}/{n} = {100 * s['n_exact'] / n:.1f} %")
    json.dump(out, open(sys.argv[1], "w"), indent=0)
