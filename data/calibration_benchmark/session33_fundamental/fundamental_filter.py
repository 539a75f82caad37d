"""Session 33 filter: the periodic-motion fundamental the loop's own detector finds on each record
(prepared record, no loop run). Run from each tree (main, change) and compare: only records whose
fundamental differs can change.
Usage (from the tree to be measured): python fundamental_filter.py OUT.json GEN:LO-HI ...
"""
import sys, os, json, importlib, tempfile, pathlib
from concurrent.futures import ProcessPoolExecutor
sys.path.insert(0, os.getcwd())
GEN = {"independent": "plant.calibration.bench_records", "blind": "plant.calibration.blind_records"}


def one(job):
    gen, s = job
    from plant.calibration.fit import prepare
    from plant.calibration.io import load_record
    from plant.calibration.loop import periodic_motion
    r = importlib.import_module(GEN[gen]).make_record(s)
    d = pathlib.Path(tempfile.mkdtemp()); r.write_csv(d / "r.csv")
    f, share, k = periodic_motion(prepare(load_record(d / "r.csv")))
    return [gen, s, f, share, k, list(r.hidden), r.meta.get("trajectory")]


if __name__ == "__main__":
    jobs = []
    for spec in sys.argv[2:]:
        gen, rng = spec.split(":"); lo, hi = map(int, rng.split("-"))
        jobs += [(gen, s) for s in range(lo, hi + 1)]
    with ProcessPoolExecutor(2) as ex:
        out = list(ex.map(one, jobs))
    json.dump(out, open(sys.argv[1], "w"))
    print(sum(o[2] is not None for o in out), "periodic of", len(out))
