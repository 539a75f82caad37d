import sys
sys.path.insert(0, ".")
import numpy as np
from plant.calibration import blind_records as B, loop
from plant.calibration.fit import prepare
from plant.calibration.io import Record
for s in [3, 47, 107, 123, 136, 144, 1, 5]:
    r = B.make_record(s)
    rec = Record(name=f"b{s}", t_s=r.t_s, position=r.position_rad, torque=r.torque_nm)
    p = prepare(rec)
    v = np.abs(p.dq); thr = 0.05 * np.percentile(v, 99)
    idx = np.nonzero(v > thr)[0]; i0, i1 = idx[0], idx[-1] + 1
    t0, t1 = p.t[i0], p.t[i1 - 1]
    m = (r.t_s >= t0) & (r.t_s <= t1)
    sub = Record(name="m", t_s=r.t_s[m] - r.t_s[m][0], position=r.position_rad[m], torque=r.torque_nm[m])
    f, share, k = loop.periodic_motion(prepare(sub))
    print(s, r.hidden, r.meta["trajectory"], f"moving {t0:.1f}-{t1:.1f} of {r.t_s[-1]:.1f}s", f, round(share, 3), k)
