import sys
sys.path.insert(0, "/work/main")
import numpy as np
import plant.calibration.fit as F
from plant.calibration.io import load_record
rec = load_record(sys.argv[1])
for cut in (None, 10.0, 20.0):
    p = F.prepare(rec, cutoff_hz=cut)
    fit = F.fit_model(p, F.ModelSpec())
    names, X = F.design(p, F.ModelSpec())
    r = p.y_dec - X @ fit.coef
    # share of residual variance in 3.4-4.0 Hz band (on the kept samples, treated as uniform)
    fs = 1 / (p.dt_s * p.decim)
    R = np.abs(np.fft.rfft(r - r.mean()))**2; f = np.fft.rfftfreq(r.size, 1/fs)
    band = (f > 3.4) & (f < 4.0)
    print(cut, p.cutoff_hz, p.decim, f"rms={np.sqrt(np.mean(r**2)):.4f}", f"share 3.4-4 Hz={R[band].sum()/R.sum():.3f}", dict(zip(names, np.round(fit.coef, 3))), flush=True)
