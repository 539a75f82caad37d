"""Session 60: the rank test's 40 batch means (d as % of the current model's mean loss, and that loss per batch)
for the candidate whose held-out gain is TARGET % on one record (used independent 27126: asymmetric friction,
gain 56.51 %, z = 1.8). Usage (repository root): python .../batch_means.py GENERATOR SEED TARGET; with INTERLEAVE=1 in the environment
the folds are `probe_interleave.py`'s (40 blocks, fold = block mod 8; used 27126: TARGET 80.09)."""
import sys, os, json
import numpy as np
sys.path.insert(0, os.getcwd()); sys.path.insert(0, "data/calibration_benchmark/session25_sweep_guard")
import runner
from plant.calibration import loop
if os.environ.get("INTERLEAVE") == "1":
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import probe_interleave  # noqa: F401  (patches loop.cv_losses_xy and two_mass.cv_losses_xy)
orig = loop.cv_compare
target = float(sys.argv[3])
def wrap(err0, err1, n_batches=40):
    g, z = orig(err0, err1, n_batches)
    if abs(g - target) < 0.05:
        e0 = np.asarray(err0); e1 = np.asarray(err1)
        d = e0**2 - e1**2; m0 = np.mean(e0**2)
        B = loop.rank_batches(d.size, n_batches)
        edges = np.linspace(0, d.size, B + 1).astype(int)
        bm = np.add.reduceat(d, edges[:-1]) / np.diff(edges)
        print("gain", g, "z", z, "n", d.size, "B", B)
        print("batch d / m0 (%):", " ".join(f"{100*b/m0:.0f}" for b in bm))
        lb = np.add.reduceat(e0**2, edges[:-1]) / np.diff(edges)
        print("batch loss0 / m0:", " ".join(f"{b/m0:.2f}" for b in lb))
    return g, z
loop.cv_compare = wrap
mod, r, rep, wall = runner.calibrate_record(sys.argv[1], sys.argv[2])
