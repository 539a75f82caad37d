"""Session 51 exploration: every accepted effect's held-out gain, share and z, with whether the
record hides its kind (used records only). Usage (cwd = tree to run): python effects_runner.py OUT.json GEN:LO-HI ..."""
import json, os, pathlib, sys
sys.path.insert(0, os.getcwd())
T = pathlib.Path(os.getcwd()) / "data/calibration_benchmark"
sys.path.insert(0, str(T / "session25_sweep_guard")); sys.path.insert(0, str(T / "tools"))
from jobs import map_jobs, seed_jobs
import runner as base

def one(job):
    gen, seed = job
    mod, r, rep, wall = base.calibrate_record(gen, str(seed))
    lib = set(mod.LIBRARY_KINDS)
    hid = {h for h in r.hidden if h in lib}
    named = [e["kind"] for e in rep["effects"]]
    return {"generator": gen, "seed": seed, "hidden": list(r.hidden), "named": named, "exact": set(named) == hid,
            "effects": [{"kind": e["kind"], "true": e["kind"] in hid, "explained_pct": e["variance_explained_pct"],
                         "cv_gain_pct": e["cv_gain_pct"], "cv_z": e["cv_z"]} for e in rep["effects"]],
            "unexplained": [u.get("kind") or u.get("domain") for u in rep["unexplained"]], "wall_s": wall}

if __name__ == "__main__":
    out = map_jobs(one, seed_jobs(sys.argv[2:]))
    json.dump(out, open(sys.argv[1], "w"), indent=1)
    print("records", len(out), "exact", sum(o["exact"] for o in out))
