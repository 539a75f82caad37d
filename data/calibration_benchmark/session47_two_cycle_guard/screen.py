"""Session 47 (second change): which records the two-cycle phase guard can act on, from the record alone.

The change (`change.diff`) adds a second search to ``loop.periodic_motion``: when the first (≥ 3
cycles, up to 15 harmonics: main's search, unchanged as ``_periodic_search``) finds no periodic
motion, a motion that 3 harmonics describe with ≥ 2 cycles is periodic too. Main and the change
compute the same thing on every record where that second search does not fire. Run from the change's
tree: a record acts when ``periodic_motion`` (the change) finds a fundamental and main's search
(``_periodic_search`` with ``PERIODIC_MIN_CYCLES``, ``PERIODIC_MAX_HARMONICS``) does not.

Usage (repository root of the change's tree): python screen.py OUT.json GEN:LO-HI ...
Output: OUT.json, one entry per record: generator, seed, hidden, f_hz (change), cycles, acts.
"""
import os, pathlib, sys
sys.path.insert(0, os.getcwd())
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "tools"))
from screening import prepared_record, run_screen


def one(job):
    from plant.calibration import loop
    gen, seed = job
    rec, _, prep = prepared_record(gen, seed)
    f_new, _, _ = loop.periodic_motion(prep)
    t, v, v0, var, dt_rows = loop._velocity_rows(prep)
    f_main = (loop._periodic_search(t, v, v0, var, dt_rows, loop.PERIODIC_MIN_CYCLES, loop.PERIODIC_MAX_HARMONICS)[0]
              if t.size >= 16 and t[-1] > 0 and var > 0 else None)
    return {"generator": gen, "seed": seed, "hidden": list(rec.hidden), "f_hz": f_new,
            "cycles": (f_new * float(t[-1])) if f_new else None, "acts": f_new is not None and f_main is None}


if __name__ == "__main__":
    run_screen(one, sys.argv, __doc__)
