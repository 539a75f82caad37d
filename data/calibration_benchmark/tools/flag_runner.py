"""Session 24's runner (`session25_sweep_guard/runner.py`: records of either generator through
`calibrate`, the drive's stiffness declared as the benchmark does) plus a flag per record: whether
PHRASE occurs in the report's rejected candidates, effects or log (the log since session 42) — i.e. whether a change's rule acted
in that record (session 38's decisions run the change on all records and main only where it acted;
elsewhere the two runs are the same computation). With --two-mass only the records whose planned
hidden set holds backlash or a compliant mode are run (the generators' `plan()`).

Usage (from the tree whose loop is to be run):
    python flag_runner.py (PHRASE | --function [MODULE.]NAME) [--two-mass] OUT.json (GEN:LO-HI ... | --seeds-from FILE)
Output: one line per record (generator, seed, hidden, named, OK/BAD, "flag" where PHRASE occurred)
and OUT.json, session 24's fields plus ``flag``.

Since session 52: PHRASE is also searched in ``unexplained`` and ``undecided``; ``--function NAME``
flags instead where ``plant.calibration.loop.NAME`` returned something other than None (a rule that
refused, as sessions 49-51's runners did by hand: `session49_heating_drift/heating_runner.py`,
`session50_spring_seed/spring_seed_runner.py`, `session51_share_floor/floor_runner.py`; ``n_flagged_calls``
counts the calls). In a tree without NAME (main, before the change) the flag is always false. Since
session 52 the loop evaluates its geometry rules (``_static_refusals``: the share floor, resolution,
stick, alias, inertia) for every candidate with a positive gain, not only for those that passed the
rank test, so flagging one of them flags more records than the rule acts on: safe (main then runs
more records), not exact.
``--seeds-from FILE`` runs the (generator, seed) pairs of a JSON list of objects with ``generator``
and ``seed`` (e.g. the change's flagged records) instead of ranges.

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
CALLS = {"n": 0}   # --function: calls of the wrapped function that returned something, this record
_cal = base.calibrate_record


def calibrate_record(gen, arg):
    mod, r, rep, wall = _cal(gen, arg)
    # the report's log too since session 42 (its rule's phrase is a log line: where it acts, nothing else
    # need change in the report); unexplained and undecided since session 52
    calibrate_record.flag = PHRASE is not None and PHRASE in json.dumps(
        [rep.get(k, []) for k in ("rejected", "effects", "log", "unexplained", "undecided")])
    return mod, r, rep, wall


def wrap_function(name):
    """Wrap ``plant.calibration.loop.<name>`` (or ``plant.calibration.<module>.<name>`` for ``module.name``)
    so that each call returning something other than None counts in ``CALLS``; the module looks its
    functions up at call time, so the wrapper is what runs (a caller in another module that imported the
    name itself would not see it). False if the tree has no such function. Session 58's second decision
    passed ``first_direction``, a function of ``fit``, and so flagged nothing."""
    import importlib
    modname, _, name = name.rpartition(".")
    loop = importlib.import_module(f"plant.calibration.{modname or 'loop'}")
    if not hasattr(loop, name):
        return False
    fn = getattr(loop, name)

    def counted(*a, **k):
        out = fn(*a, **k)
        if out is not None:
            CALLS["n"] += 1
        return out

    setattr(loop, name, counted)
    return True


base.calibrate_record = calibrate_record


def one(job):
    gen, seed = job
    if TWO_MASS_ONLY:
        mod = importlib.import_module(GEN[gen])
        if not TWO_MASS & set(mod.plan()[seed % len(mod.plan())]):
            return None
    CALLS["n"] = 0
    o = base.one((gen, str(seed)))
    o["flag"] = bool(getattr(calibrate_record, "flag", False)) or CALLS["n"] > 0
    o["n_flagged_calls"] = CALLS["n"]
    return o


if __name__ == "__main__":
    args = sys.argv[1:]
    if len(args) < 3:
        sys.exit(__doc__)
    if args[0] == "--function":
        args.pop(0)
        name = args.pop(0)
        where = name if "." in name else f"loop.{name}"
        print(f"flag: calls of {where} that returned something" if wrap_function(name)
              else f"flag: {where} does not exist in this tree, the flag is always false", flush=True)
    else:
        PHRASE = args.pop(0)
    if args[0] == "--two-mass":
        TWO_MASS_ONLY = True
        args.pop(0)
    out_path, specs = args[0], args[1:]
    if specs[:1] == ["--seeds-from"]:
        if len(specs) != 2:
            sys.exit("--seeds-from takes one FILE (a JSON list of objects with generator and seed)")
        jobs = [(o["generator"], int(o["seed"])) for o in json.load(open(specs[1]))]
    else:
        jobs = seed_jobs(specs)
    out = map_jobs(one, jobs, chunksize=2)
    for o in out:
        print(o["generator"], o["seed"], o["hidden"], o["named"], "OK " if o["exact"] else "BAD", "flag" if o["flag"] else "",
              flush=True)
    json.dump(out, open(out_path, "w"), indent=1)
    print("exact", sum(o["exact"] for o in out), "/", len(out), "flag in", sum(o["flag"] for o in out))
