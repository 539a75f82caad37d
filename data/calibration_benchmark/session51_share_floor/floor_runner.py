"""Session 51 runner: records of ``GEN:LO-HI`` arguments through ``calibrate`` as
``benchmark-calibration`` does (session 24's runner), with ``flag`` true where
``plant.calibration.loop._below_share_floor`` refused some candidate — the only way the session's
change can act (a candidate it does not refuse goes on exactly as in main). In main's tree the
function does not exist and the flag is always false; main is run on the flagged records and on a
random sample of the others (session 49's practice), whose named sets must then equal the change's.

Usage (from the tree whose loop is to be run): python floor_runner.py OUT.json GEN:LO-HI ... [--seeds-from FILE]
``--seeds-from FILE``: run only the (generator, seed) pairs listed in FILE (a JSON list of objects
with ``generator`` and ``seed``), e.g. the change's flagged records.
"""
import json, os, pathlib, sys
sys.path.insert(0, os.getcwd())
here = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(here.parent / "session25_sweep_guard"))
sys.path.insert(0, str(here.parent / "tools"))
from jobs import map_jobs, seed_jobs
import runner as base
from plant.calibration import loop

FLAG = {"n": 0}
if hasattr(loop, "_below_share_floor"):
    _floor = loop._below_share_floor

    def below_share_floor(c, cfg):
        why = _floor(c, cfg)
        if why is not None:
            FLAG["n"] += 1
        return why

    loop._below_share_floor = below_share_floor


def one(job):
    gen, seed = job
    FLAG["n"] = 0
    o = base.one((gen, str(seed)))
    o["flag"] = FLAG["n"] > 0
    o["n_refused_by_floor"] = FLAG["n"]
    return o


if __name__ == "__main__":
    args = [a for a in sys.argv[2:] if not a.startswith("--seeds-from")]
    if "--seeds-from" in sys.argv:
        src = json.load(open(sys.argv[sys.argv.index("--seeds-from") + 1]))
        jobs = [(o["generator"], int(o["seed"])) for o in src]
        args = [a for a in args if a != sys.argv[sys.argv.index("--seeds-from") + 1]]
    else:
        jobs = seed_jobs(args)
    if not jobs:
        sys.exit(__doc__)
    out = map_jobs(one, jobs)
    for o in out:
        print(o["generator"], o["seed"], o["hidden"], o["named"], "OK " if o["exact"] else "BAD",
              "flag" if o["flag"] else "", flush=True)
    json.dump(out, open(sys.argv[1], "w"), indent=1)
    print("records", len(out), "exact", sum(o["exact"] for o in out), "flagged", sum(o["flag"] for o in out))
