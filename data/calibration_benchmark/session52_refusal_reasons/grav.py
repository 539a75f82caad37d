import sys, os, tempfile, importlib, dataclasses
sys.path.insert(0, os.getcwd())
import numpy as np
from plant.calibration.io import load_record
from plant.calibration.fit import prepare, fit_model, ModelSpec, design
from plant.calibration import loop
GEN = {"independent": "plant.calibration.bench_records", "blind": "plant.calibration.blind_records"}
gen, seed = sys.argv[1], int(sys.argv[2])
rec = importlib.import_module(GEN[gen]).make_record(seed)
d = tempfile.mkdtemp(); rec.write_csv(d + "/r.csv")
prep = prepare(load_record(d + "/r.csv"))
base, strib = loop.fit_baseline(prep)
print("base", dict(zip(base.names, np.round(base.coef, 3))) if hasattr(base,'coef') else base.names)
g = fit_model(prep, dataclasses.replace(base.spec.copy(), gravity=True))
for f in (base, g):
    print([ (n, round(f.param(n),3)) for n in f.names], "rss", f.rss)
l0 = loop.cv_losses(prep, base.spec); l1 = loop.cv_losses(prep, g.spec)
n = l0.size; edges = np.linspace(0, n, 9).astype(int)
q = prep.q_dec; dq = prep.dq_dec
for a, b in zip(edges[:-1], edges[1:]):
    print(f"fold {a}-{b}: q {q[a:b].min():.3f}..{q[a:b].max():.3f} dq± {np.mean(dq[a:b]>0):.2f} loss0 {np.mean(l0[a:b]**2):.4f} loss1 {np.mean(l1[a:b]**2):.4f} ext1 {l1.extrapolated[a:b].mean():.2f} ext0 {l0.extrapolated[a:b].mean():.2f}")
print(loop.cv_compare(l0, l1))
