"""Session 38 (third change) runner: session 24's runner (`session25_sweep_guard/runner.py`, records of
either generator through `calibrate` as the benchmark runs them) plus ``fired``: whether the line-alias
rule refused a candidate anywhere in the run (its reason contains "the direction-dependent part of the model").
Usage (from the tree whose loop is to be run): python runner.py OUT.json GEN:LO-HI ..."""
import json, os, pathlib, sys
sys.path.insert(0, os.getcwd())
here = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(here.parent / "session25_sweep_guard"))
sys.path.insert(0, str(here.parent / "tools"))
from jobs import map_jobs, seed_jobs
import runner as base

_cal = base.calibrate_record


def calibrate_record(gen, arg):
    mod, r, rep, wall = _cal(gen, arg)
    calibrate_record.fired = "the direction-dependent part of the model" in json.dumps(rep.get("rejected", []))
    return mod, r, rep, wall


base.calibrate_record = calibrate_record


def one(job):
    gen, seed = job
    o = base.one((gen, str(seed)))
    o["fired"] = bool(getattr(calibrate_record, "fired", False))
    return o


if __name__ == "__main__":
    out = map_jobs(one, seed_jobs(sys.argv[2:]), chunksize=2)
    for o in out:
        print(o["generator"], o["seed"], o["hidden"], o["named"], "OK " if o["exact"] else "BAD", "fired" if o["fired"] else "", flush=True)
    json.dump(out, open(sys.argv[1], "w"), indent=1)
    print("exact", sum(o["exact"] for o in out), "/", len(out), "fired in", sum(o["fired"] for o in out))
