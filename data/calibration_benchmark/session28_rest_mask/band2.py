import sys
sys.path.insert(0, "/work/wt28")
import numpy as np
import plant.calibration.fit as F
from plant.calibration.io import load_record
rec = load_record(sys.argv[1])
pA = F.prepare(rec)
fA = F.fit_model(pA, F.ModelSpec())
for d in (4, 8, 20):
    p = F.prepare(rec, decimate=d)
    names, X = F.design(p, F.ModelSpec())
    r_same = p.y_dec - X @ fA.coef
    f = F.fit_model(p, F.ModelSpec())
    r_fit = p.y_dec - X @ f.coef
    print(d, p.y_dec.size, "rms with A's coef", np.sqrt(np.mean(r_same**2)), "refit", np.sqrt(np.mean(r_fit**2)), "fit.rss", np.sqrt(f.rss/p.y_dec.size), dict(zip(names, f.coef.round(3))))
