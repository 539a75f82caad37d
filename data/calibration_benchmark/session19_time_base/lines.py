"""For a seed: calibrate with the current code, then for every named time/position line fit the line on the
final residual (without that line) separately on slow and fast moving samples."""
import sys, json, tempfile, pathlib, numpy as np
sys.path.insert(0, "/work/main")
from plant.calibration.bench_records import make_record
from plant.calibration.io import load_record
from plant.calibration.fit import prepare, fit_model
from plant.calibration import loop
from concurrent.futures import ProcessPoolExecutor
def one(seed):
    r = make_record(seed)
    d = pathlib.Path(tempfile.mkdtemp(prefix=f"ln{seed}_")); r.write_csv(d / "rec.csv")
    prep = prepare(load_record(d / "rec.csv"))
    res = loop.run_loop(prep)
    spec = res.final.spec
    v = np.abs(prep.dq_dec); med = np.median(v); t = prep.t_dec; q = prep.q_dec
    out = []
    for kind, lst in (("time", spec.time_frequencies), ("pos", spec.position_periods)):
        for i, val in enumerate(list(lst)):
            s2 = spec.copy(); getattr(s2, "time_frequencies" if kind == "time" else "position_periods").pop(i)
            f = fit_model(prep, s2, refine=False); rr = f.residual
            arg = 2*np.pi*val*t if kind == "time" else 2*np.pi*q/val
            row = []
            for m in (v < med, v >= med):
                X = np.c_[np.sin(arg[m]), np.cos(arg[m])]
                c, *_ = np.linalg.lstsq(X, rr[m], rcond=None)
                e = rr[m] - X @ c; se = np.sqrt(np.sum(e**2)/(m.sum()-2) * 2/m.sum())
                row.append((float(np.hypot(*c)), float(np.arctan2(c[1], c[0])), float(se)))
            out.append((kind, val, row))
    return seed, r.hidden, r.meta["trajectory"], r.truth, out
seeds = [int(x) for x in sys.argv[1:]]
with ProcessPoolExecutor(2) as ex:
    for seed, hid, traj, truth, out in ex.map(one, seeds):
        print(seed, hid, traj, truth)
        for kind, val, row in out:
            (a1,p1,s1),(a2,p2,s2) = row
            print(f"   {kind} {val:.5g}: slow {a1:.4g}±{s1:.2g} ph {p1:+.2f} | fast {a2:.4g}±{s2:.2g} ph {p2:+.2f}", flush=True)
