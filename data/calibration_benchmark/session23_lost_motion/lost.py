"""Measure in the generator's own states the lost motion at each reversal: motor travel from the motor's
reversal until the load has moved 2 % of the gap in the new direction."""
import os, sys, math, re, inspect, types
import numpy as np
sys.path.insert(0, os.getcwd())
import plant.calibration.bench_records as B
src = inspect.getsource(B._simulate.py_func)
src = src.replace("@_jit\n", "")
src = src.replace("th_out = np.zeros(n)", "th_out = np.zeros(n)\n    thl_out = np.zeros(n)\n    tc_out = np.zeros(n)")
src = src.replace("th_out[i] = thm", "th_out[i] = thm\n        thl_out[i] = thl\n        tc_out[i] = tc if two_mass else 0.0")
src = src.replace("return cmd_out, shaft_out, th_out", "return cmd_out, shaft_out, th_out, thl_out, tc_out")
src = src.replace("    tq = 0.0\n", "    tq = 0.0\n    tc = 0.0\n", 1)
ns = dict(B.__dict__)
exec(src, ns)
sim2 = B._jit(ns["_simulate"])
captured = {}
def fake(v_ref, ctrl_dt, n_sub, log_every, p):
    out = sim2(v_ref, ctrl_dt, n_sub, log_every, p)
    captured.update(thl=out[3], tc=out[4], thm=out[2], dt=ctrl_dt, p=p, vref=v_ref)
    return out[:3]
B._simulate = fake
for s in sys.argv[1:]:
    r = B.make_record(int(s), ("backlash",) if int(s) >= 3000 else None)
    thm, thl, tc = captured["thm"], captured["thl"], captured["tc"]
    b = r.truth["backlash"]["width_rad"]; res = 1 / r.meta["counts_per_rad"]
    k = r.meta["two_mass"]["stiffness_nm_rad"]; fc = r.meta["fc"]; fs = fc * r.meta["fs_ratio"]
    vm = np.gradient(thm); vl = np.gradient(thl)
    # motor reversals: sign changes of motor velocity with |travel| since last > 20 b
    sgn = np.sign(vm)
    lost = []
    i = 1; last_rev = 0
    idx = np.flatnonzero((sgn[1:] != sgn[:-1]) & (sgn[1:] != 0)) + 1
    revs = []
    for j in idx:
        if not revs or abs(thm[j] - thm[revs[-1]]) > 20 * b:
            revs.append(j)
    for a, j in enumerate(revs):
        d = sgn[j]
        end = revs[a + 1] if a + 1 < len(revs) else len(thm)
        seg_l = thl[j:end]; seg_m = thm[j:end]
        moved = np.flatnonzero(d * (seg_l - thl[j]) > b * 0.02)
        if moved.size:
            m = moved[0]
            lost.append(abs(seg_m[m] - thm[j]))
    lost = np.array(lost)
    print(s, r.meta["trajectory"], f"gap {b:.3g}  lost/gap median {np.median(lost)/b:.2f} [{lost.min()/b:.2f}..{lost.max()/b:.2f}] n={lost.size}"
          f"  quasi-static (b+(fc+fs)/k)/b {(b + (fc + fs) / k) / b:.2f}  fres {r.meta['two_mass']['resonance_hz']:.0f}")
