"""Probe: does the clean long record's invention come from its length or from its coarser fit band?"""
import json, sys, time
sys.path.insert(0, "/work/wt28")
from plant.calibration.bench_records import make_record
from plant.calibration.report import calibrate
out = {}
for seed, n in [(int(a.split(":")[0]), int(a.split(":")[1])) for a in sys.argv[2:]]:
    rec = make_record(seed, n_samples=n)
    p = f"/tmp/probe28/rec_{seed}_{n}.csv"
    rec.write_csv(p)
    t0 = time.time()
    rep = calibrate(p, f"/tmp/probe28/run_{seed}_{n}", plots=False)
    named = [e["kind"] for e in rep["effects"]]
    out[f"{seed}:{n}"] = {"named": named, "wall_s": time.time() - t0, "unexplained": [u.get("domain") for u in rep["unexplained"]]}
    print(seed, n, named, f"{time.time()-t0:.0f}s", flush=True)
json.dump(out, open(sys.argv[1], "w"), indent=1)
