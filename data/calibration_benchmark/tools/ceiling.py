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
from host.calibration_benchmark import miss_class, record_motion


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
        rs = [r for r in runs if r["generator"] == gen]
        if not rs:
            continue
        c = collections.Counter()
        for r in rs:
            m = ms[(gen, r["seed"])]
            cls = miss_class({**r, "motion": m}) or "exact"
            c[cls] += 1
            out.append({"generator": gen, "seed": r["seed"], **m, "hidden": r["hidden"], "named": r["named"], "class": cls})
        n = len(rs)
        ab = n - sum(v for k, v in c.items() if k != "exact" and set(k) & set("AB"))
        abc = n - sum(v for k, v in c.items() if k != "exact" and set(k) & set("ABC"))
        print(f"{gen}: {n} records; " + ", ".join(f"{k} {v}" for k, v in sorted(c.items(), key=lambda x: -x[1])))
        print(f"  exact sets nameable at all (no A or B miss): {ab}/{n} = {100 * ab / n:.1f} %; at the loop's level "
              f"(no A, B or C miss): {abc}/{n} = {100 * abc / n:.1f} %; named: {c['exact']}/{n} = {100 * c['exact'] / n:.1f} %")
    json.dump(out, open(sys.argv[1], "w"), indent=0)
