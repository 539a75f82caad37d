import sys
sys.path.insert(0, "/work/main")
import numpy as np
import plant.calibration.fit as F
from plant.calibration.io import load_record
rec = load_record(sys.argv[1])
pA = F.prepare(rec)
fA = F.fit_model(pA, F.ModelSpec())
names, Xf = F.design_full(pA, F.ModelSpec())
rf = pA.y - Xf @ fA.coef
v = pA.dq
v_still = 0.02 * float(np.percentile(np.abs(pA.dq_dec), 95))
rest = np.abs(v) < v_still
print("v_still", v_still, "rest share", rest.mean(), "full-rate rms", np.sqrt(np.mean(rf**2)), "rms moving", np.sqrt(np.mean(rf[~rest]**2)), "rms rest", np.sqrt(np.mean(rf[rest]**2)))
# one reversal region
i0 = np.flatnonzero(rest)[200]
for i in range(i0-30, i0+60, 3):
    print(f"{pA.t[i]:8.3f} dq={v[i]: .5f} rest={int(rest[i])} y={pA.y[i]: 8.3f} model={Xf[i]@fA.coef: 8.3f} r={rf[i]: 7.3f}")
