"""Session 50 runner: the records of ``GEN:LO-HI`` arguments whose generator declares the drive's
stiffness (``meta['two_mass']['stiffness_nm_rad']``, as ``benchmark-calibration`` does), through
``calibrate`` with it declared; ``tools/flag_runner.py``'s output, with ``flag`` true where some call
of ``plant.calibration.loop._gear_spring_losses`` was given a ``seed`` and returned a spring model —
the only way the session's change can act (otherwise ``_beats_gear_spring`` returns as main's does).
Records without a declared stiffness never call it (the spring test needs the stiffness), so they are
not run at all and only counted. Main is run only on the flagged records (session 38's practice).

Usage (from the tree whose loop is to be run): python spring_seed_runner.py OUT.json GEN:LO-HI ...
In main's tree (no seed argument) the flag is always false.
"""
import importlib, json, os, pathlib, sys
sys.path.insert(0, os.getcwd())
here = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(here.parent / "session25_sweep_guard"))
sys.path.insert(0, str(here.parent / "tools"))
from jobs import GEN, map_jobs, seed_jobs
import runner as base
from plant.calibration import loop

_losses = loop._gear_spring_losses
FLAG = {"on": False}


def gear_spring_losses(prep, cur, cfg, cache, seed=None):
    out = _losses(prep, cur, cfg, cache, seed) if seed is not None else _losses(prep, cur, cfg, cache)
    if seed is not None and out is not None:
        FLAG["on"] = True
    return out


loop._gear_spring_losses = gear_spring_losses


def one(job):
    gen, seed = job
    r = importlib.import_module(GEN[gen]).make_record(seed)
    if r.meta.get("two_mass", {}).get("stiffness_nm_rad") is None:
        return {"generator": gen, "seed": seed, "skipped": True}
    FLAG["on"] = False
    o = base.one((gen, str(seed)))
    o["flag"] = FLAG["on"]
    return o


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    out = map_jobs(one, seed_jobs(sys.argv[2:]))
    ran = [o for o in out if not o.get("skipped")]
    for o in ran:
        print(o["generator"], o["seed"], o["hidden"], o["named"], "OK " if o["exact"] else "BAD",
              "flag" if o["flag"] else "", flush=True)
    json.dump(ran, open(sys.argv[1], "w"), indent=1)
    print("records", len(out), "with a declared stiffness (run)", len(ran), "exact", sum(o["exact"] for o in ran),
          "flagged", sum(o["flag"] for o in ran))
