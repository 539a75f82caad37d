"""Session 43 probe (measured, no rule): for the blind staircases of 13660-13899, the baseline residual's share on
plateaus whose decimated velocity varies more than half its commanded value (std/|v| > 0.5: the velocity loop hunts).
The plateaus and commanded speeds are read from the generator's meta (truth), so this is a diagnosis, not a rule.
Usage (repository root): python hunting_probe.py OUT.json LO HI"""
import sys, os, json, importlib, tempfile, pathlib
import numpy as np
sys.path.insert(0, os.getcwd()); sys.path.insert(0, os.path.join(os.getcwd(), 'data/calibration_benchmark/tools'))
from jobs import map_jobs
from plant.calibration import io as cio, fit as F, loop as L
def one(seed):
    mod = importlib.import_module("plant.calibration.blind_records")
    r = mod.make_record(seed)
    if r.meta.get('trajectory') != 'staircase': return None
    d = pathlib.Path(tempfile.mkdtemp()); r.write_csv(d / "rec.csv")
    prep = F.prepare(cio.load_record(str(d / "rec.csv")))
    base, _ = L.fit_baseline(prep)
    res = base.residual; t = prep.t_dec; w = prep.dq_dec
    tot = float(res @ res); hunt_e = 0.0; cvs = []
    for t0, t1, v in r.meta['trajectory_info']['plateaus']:
        m = (t > t0 + 1.0) & (t < t1 - 0.5)
        if m.sum() < 20: continue
        cv = float(np.std(w[m]) / abs(v)); cvs.append((abs(v), cv))
        if cv > 0.5: hunt_e += float(res[m] @ res[m])
    return {"seed": seed, "rel_err": base.relative_error_pct, "hunting_share": hunt_e / tot, "n_hunting": sum(cv > 0.5 for _, cv in cvs),
            "vs": r.meta.get('stribeck_velocity_rad_s'), "min_speed": min(v for v, _ in cvs) if cvs else None,
            "cv": cvs, "hidden": list(r.hidden)}
out = [o for o in map_jobs(one, [int(s) for s in range(int(sys.argv[2]), int(sys.argv[3]) + 1)], chunksize=4) if o]
json.dump(out, open(sys.argv[1], 'w'), indent=1)
