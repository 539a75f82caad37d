"""Session 24's runner (`session25_sweep_guard/runner.py`: records of either generator through
`calibrate`, the drive's stiffness declared as the benchmark does) plus a flag per record: whether
PHRASE occurs in the report's rejected candidates, effects or log (the log since session 42) — i.e. whether a change's rule acted
in that record (session 38's decisions run the change on all records and main only where it acted;
elsewhere the two runs are the same computation). With --two-mass only the records whose planned
hidden set holds backlash or a compliant mode are run (the generators' `plan()`).

Usage (from the tree whose loop is to be run):
    python flag_runner.py PHRASE [--two-mass] OUT.json GEN:LO-HI ...
Output: one line per record (generator, seed, hidden, named, OK/BAD, "flag" where PHRASE occurred)
and OUT.json, session 24's fields plus ``flag``.

Replaces session 38's three near-copies (`session38_held_inertia/runner.py` with PHRASE
"inertia held at", `session38_line_alias/runner.py` with "the direction-dependent part of the
model", `session38_gap_vs_compliance/runner.py` with "with the load's inertia a gap" and
--two-mass); their JSON outputs name the flag ``held``, ``fired`` and ``ran``.
"""
import importlib, json, os, pathlib, sys
sys.path.insert(0, os.getcwd())
here = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(here.parent / "session25_sweep_guard"))
sys.path.insert(0, str(here))
from jobs import GEN, map_jobs, seed_jobs
import runner as base

TWO_MASS = {"backlash", "compliant_mode"}
PHRASE = None
TWO_MASS_ONLY = False
_cal = base.calibrate_record


def calibrate_record(gen, arg):
    mod, r, rep, wall = _cal(gen, arg)
    # the report's log too since session 42 (its rule's phrase is a log line: where it acts, nothing else
    # need change in the report)
    calibrate_record.flag = PHRASE in json.dumps([rep.get("rejected", []), rep.get("effects", []), rep.get("log", [])])
    return mod, r, rep, wall


base.calibrate_record = calibrate_record


def one(job):
    gen, seed = job
    if TWO_MASS_ONLY:
        mod = importlib.import_module(GEN[gen])
        if not TWO_MASS & set(mod.plan()[seed % len(mod.plan())]):
            return None
    o = base.one((gen, str(seed)))
    o["flag"] = bool(getattr(calibrate_record, "flag", False))
    return o


if __name__ == "__main__":
    args = sys.argv[1:]
    if len(args) < 3:
        sys.exit(__doc__)
    PHRASE = args.pop(0)
    if args[0] == "--two-mass":
        TWO_MASS_ONLY = True
        args.pop(0)
    out_path, specs = args[0], args[1:]
    out = map_jobs(one, seed_jobs(specs), chunksize=2)
    for o in out:
        print(o["generator"], o["seed"], o["hidden"], o["named"], "OK " if o["exact"] else "BAD", "flag" if o["flag"] else "",
              flush=True)
    json.dump(out, open(out_path, "w"), indent=1)
    print("exact", sum(o["exact"] for o in out), "/", len(out), "flag in", sum(o["flag"] for o in out))
