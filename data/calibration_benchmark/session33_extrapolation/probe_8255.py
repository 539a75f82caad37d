import sys, os, tempfile, pathlib, dataclasses
sys.path.insert(0, os.getcwd())
import numpy as np
from plant.calibration.bench_records import make_record
from plant.calibration.io import load_record
from plant.calibration.fit import prepare, fit_model, design
from plant.calibration import loop
s = int(sys.argv[1])
r = make_record(s)
d = pathlib.Path(tempfile.mkdtemp()); r.write_csv(d / "r.csv")
prep = prepare(load_record(d / "r.csv"))
base, _ = loop.fit_baseline(prep)
e0 = loop.cv_losses(prep, base.spec)
cand = dataclasses.replace(base.spec.copy(), asymmetric=True)
fc = fit_model(prep, cand)
e1 = loop.cv_losses(prep, fc.spec)
n = e0.size; edges = np.linspace(0, n, 9).astype(int)
w = prep.dq_dec
print("meta", {k: r.meta[k] for k in ("trajectory", "vmax", "travel_rad")}, "n", n)
for a, b in zip(edges[:-1], edges[1:]):
    print(f"block {a}-{b}: mse0 {np.mean(e0[a:b]**2):.4g} mse1 {np.mean(e1[a:b]**2):.4g}  w>0 {np.sum(w[a:b]>1e-3)} w<0 {np.sum(w[a:b]<-1e-3)}  |w| range {np.abs(w[a:b]).min():.3g}-{np.abs(w[a:b]).max():.3g}")
names, X = design(prep, fc.spec)
print(names)
print(fc.spec)
print({k: round(float(v), 4) for k, v in zip(names, fc.coef)} if hasattr(fc, "coef") else "")
