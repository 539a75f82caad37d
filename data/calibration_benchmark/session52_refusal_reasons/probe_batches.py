"""For used records with a hidden reversal kind: the loop's reversal count, and how many of the rank
test's batches hold a reversal; with whether the run named the kind."""
import sys, os, json, tempfile, importlib
sys.path.insert(0, os.getcwd())
sys.path.insert(0, "data/calibration_benchmark/tools")
import numpy as np
from jobs import GEN, map_jobs
from plant.calibration.io import load_record
from plant.calibration.fit import prepare
from plant.calibration import residuals as res

REV = {"presliding", "backlash"}

def job(a):
    gen, seed = a
    rec = importlib.import_module(GEN[gen]).make_record(seed)
    d = tempfile.mkdtemp()
    rec.write_csv(d + "/r.csv")
    prep = prepare(load_record(d + "/r.csv"))
    n = prep.dq_dec.size
    B = int(min(40, n // 25))
    edges = np.linspace(0, n, B + 1).astype(int)
    w = res._window_samples(prep.t_dec, 0.15)
    idx = [k for k, _ in res.reversal_indices(prep.dq_dec) if k - w >= 0 and k + w < n]
    m = len(set(np.searchsorted(edges, idx, side="right") - 1))
    return gen, seed, len(idx), m, B

if __name__ == "__main__":
    runs = [r for p in sys.argv[2:] for r in json.load(open(p))]
    runs = [r for r in runs if REV & set(r["hidden"])]
    out = map_jobs(job, [(r["generator"], r["seed"]) for r in runs], workers=1)
    o = {(g, s): (n, m, B) for g, s, n, m, B in out}
    rows = []
    for r in runs:
        n, m, B = o[(r["generator"], r["seed"])]
        for k in REV & set(r["hidden"]):
            rows.append({"generator": r["generator"], "seed": r["seed"], "kind": k, "n_rev": n, "m": m, "B": B,
                         "named": k in r["named"]})
    json.dump(rows, open(sys.argv[1], "w"), indent=0)
