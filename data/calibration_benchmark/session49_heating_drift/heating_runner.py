"""Session 49 runner: ``tools/flag_runner.py``'s records and output, with ``flag`` true where some call of
the loop's drift candidate (``plant.calibration.loop._drift_candidate``) returned a heating shape
(``ModelSpec.drift_heating``) — the only way the session's change can act (otherwise the candidate
returns main's warm-up fit). Elsewhere the change's tree and main's run the same computation, so main is
run only on the flagged records (session 38's practice).

Usage (from the tree whose loop is to be run): python heating_runner.py OUT.json GEN:LO-HI ...
In main's tree (no heating shapes) the flag is always false.
"""
import json, os, pathlib, sys
sys.path.insert(0, os.getcwd())
here = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(here.parent / "session25_sweep_guard"))
sys.path.insert(0, str(here.parent / "tools"))
from jobs import map_jobs, seed_jobs
import runner as base
from plant.calibration import loop

_drift = loop._drift_candidate
FLAG = {"on": False}


def drift_candidate(ctx):
    out = _drift(ctx)
    if getattr(out.spec, "drift_heating", False):
        FLAG["on"] = True
    return out


loop._drift_candidate = drift_candidate


def one(job):
    gen, seed = job
    FLAG["on"] = False
    o = base.one((gen, str(seed)))
    o["flag"] = FLAG["on"]
    return o


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    out = []
    for o in map_jobs(one, seed_jobs(sys.argv[2:])):
        out.append(o)
    for o in out:
        print(o["generator"], o["seed"], o["hidden"], o["named"], "OK " if o["exact"] else "BAD",
              "flag" if o["flag"] else "", flush=True)
    json.dump(out, open(sys.argv[1], "w"), indent=1)
    print("exact", sum(o["exact"] for o in out), "/", len(out), "flagged", sum(o["flag"] for o in out))
