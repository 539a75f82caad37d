import sys
sys.path.insert(0, ".")
import numpy as np
from plant.calibration import blind_records as B
for s in [3, 47, 107]:
    r = B.make_record(s); ti = r.meta["trajectory_info"]
    t = r.t_s; v = np.gradient(r.position_rad, t)
    step = max(1, int(len(t) / 4000)); t = t[::step]; v = v[::step]
    P = 2 * (ti["range_rad"] / ti["rate_rad_s"] + 2 * ti["rate_rad_s"] / ti["a_max_rad_s2"])
    for lab, msk in (("all", np.ones_like(t, bool)), ("moving", np.abs(v) > 0.05 * ti["rate_rad_s"])):
        i = np.nonzero(msk)[0]; sl = slice(i[0], i[-1] + 1); tt, vv = t[sl], v[sl]
        v0 = vv - vv.mean(); var = v0 @ v0
        out = []
        for K in (3, 9, 15):
            best = 0
            for f in np.linspace(0.97, 1.03, 31) / P:
                cols = [np.ones_like(tt)] + [g(2*np.pi*k*f*tt) for k in range(1, K+1) for g in (np.sin, np.cos)]
                X = np.column_stack(cols); c, *_ = np.linalg.lstsq(X, vv, rcond=None); res = vv - X @ c
                best = max(best, 1 - res @ res / var)
            out.append(round(best, 3))
        print(s, lab, "P %.1f s, cycles %.2f" % (P, (tt[-1]-tt[0]) / P), "share K=3,9,15", out)
