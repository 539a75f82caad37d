"""Session 60 probe (used records): blocked CV with interleaved folds (NB blocks, fold = block mod k)."""
import sys, os, json
import numpy as np
sys.path.insert(0, os.getcwd())
sys.path.insert(0, "data/calibration_benchmark/tools")
sys.path.insert(0, "data/calibration_benchmark/session25_sweep_guard")
from jobs import map_jobs, seed_jobs
NB = int(os.environ.get("NB", "40"))
from plant.calibration import loop


def cv_losses_xy(names, X, y, k_folds=8):
    n = y.size
    edges = np.linspace(0, n, NB + 1).astype(int)
    fold = np.empty(n, dtype=int)
    for i, (a, b) in enumerate(zip(edges[:-1], edges[1:])):
        fold[a:b] = i % k_folds
    pred = np.empty(n)
    ext = np.zeros(n, dtype=bool)
    for f in range(k_folds):
        te = fold == f
        tr = ~te
        coef, _ = loop._solve(X[tr], y[tr], names)
        pred[te] = X[te] @ coef
        ext[te] = loop.hidden_extrapolation(X[tr], X[te])
    err = (y - pred).view(loop.CVErrors)
    err.extrapolated = ext
    return err


loop.cv_losses_xy = cv_losses_xy
from plant.calibration import two_mass
two_mass.cv_losses_xy = cv_losses_xy
import runner


def one(job):
    gen, seed = job
    o = runner.one((gen, str(seed)))
    return o


if __name__ == "__main__":
    res = map_jobs(one, seed_jobs(sys.argv[2:]), chunksize=2)
    json.dump(res, open(sys.argv[1], "w"), indent=1, default=str)
    print("exact", sum(o["exact"] for o in res), "/", len(res))
