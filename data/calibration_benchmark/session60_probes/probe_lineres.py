"""Session 60 probe (used records): every candidate the line-resolution rule refuses, with its gain, z,
quanta, frequency, and the record's hidden lines (truth)."""
import sys, os, json, re
sys.path.insert(0, os.getcwd())
sys.path.insert(0, "data/calibration_benchmark/tools")
sys.path.insert(0, "data/calibration_benchmark/session25_sweep_guard")
from jobs import map_jobs, seed_jobs
import runner


def one(job):
    gen, seed = job
    mod, r, rep, wall = runner.calibrate_record(gen, str(seed))
    out = []
    for x in rep["rejected"]:
        if "line_resolution" in (x.get("rules") or []):
            m = re.search(r"motion of ([0-9.e+-]+) position quanta", x["reason"] + " " + json.dumps(x.get("also", "")))
            out.append({k: x.get(k) for k in ("kind", "step", "cv_gain_pct", "cv_z", "rules", "frequency_hz", "period_rad", "line")}
                       | {"n_q": float(m.group(1)) if m else None, "reason": x["reason"][:160]})
    lv = [float(m.group(1)) for x in rep["rejected"] for m in [re.search(r"needs (?:> 0 and )?z ≥ ([0-9.]+)", x["reason"])] if m]
    return {"level": lv[0] if lv else None, "generator": gen, "seed": seed, "hidden": list(r.hidden),
            "truth": {k: v for k, v in r.truth.items() if "periodic" in k},
            "named": [e["kind"] for e in rep["effects"]], "refused": out, "wall_s": wall}


if __name__ == "__main__":
    res = map_jobs(one, seed_jobs(sys.argv[2:]), chunksize=2)
    json.dump(res, open(sys.argv[1], "w"), indent=1, default=str)
    print("done", len(res))
