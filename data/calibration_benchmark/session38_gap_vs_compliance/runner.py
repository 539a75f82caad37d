"""Session 38 (fourth change) runner: the never-used records whose hidden set holds backlash or a
compliant mode (the generators' `plan()`), through session 24's runner (`calibrate` with the drive's
stiffness declared, as the benchmark runs them), plus ``ran``: whether the gap-against-compliance
test ran in the record (a reason or evidence containing "with the load's inertia a gap").
Usage (from the tree whose loop is to be run): python runner.py OUT.json GEN:LO-HI ..."""
import importlib, json, os, pathlib, sys
sys.path.insert(0, os.getcwd())
here = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(here.parent / "session25_sweep_guard"))
sys.path.insert(0, str(here.parent / "tools"))
from jobs import GEN, map_jobs, seed_jobs
import runner as base

_cal = base.calibrate_record
TWO_MASS = {"backlash", "compliant_mode"}


def calibrate_record(gen, arg):
    mod, r, rep, wall = _cal(gen, arg)
    calibrate_record.ran = "with the load's inertia a gap" in json.dumps([rep.get("rejected", []), rep.get("effects", [])])
    return mod, r, rep, wall


base.calibrate_record = calibrate_record


def one(job):
    gen, seed = job
    mod = importlib.import_module(GEN[gen])
    if not TWO_MASS & set(mod.plan()[seed % len(mod.plan())]):
        return None
    o = base.one((gen, str(seed)))
    o["ran"] = bool(getattr(calibrate_record, "ran", False))
    return o


if __name__ == "__main__":
    out = map_jobs(one, seed_jobs(sys.argv[2:]), chunksize=4)
    for o in out:
        print(o["generator"], o["seed"], o["hidden"], o["named"], "OK " if o["exact"] else "BAD", "ran" if o["ran"] else "", flush=True)
    json.dump(out, open(sys.argv[1], "w"), indent=1)
    print("exact", sum(o["exact"] for o in out), "/", len(out), "ran in", sum(o["ran"] for o in out))
