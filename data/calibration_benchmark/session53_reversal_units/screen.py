"""Session 53: which records the change can act on, from the record alone (no loop run).

Session 46's screen (`../session46_reversal_units/screen.py`) with the change's rule for units: the
record's turning points are units only when there are at most ``UNIT_MAX`` (40) of them
(``plant.calibration.residuals.reversal_units`` returns None labels otherwise);
the change acts on records with at least ``min_events + UNIT_SPARE`` (14) units. On every other record
the change computes the same named set as main. The record is read as `calibrate` reads it.

Usage (repository root, the change's tree): python screen.py OUT.json GEN:LO-HI ...
Output: OUT.json, one entry per record: generator, seed, hidden, n_turning_points, n_units, acts.
"""
import json, os, pathlib, sys
sys.path.insert(0, os.getcwd())
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "tools"))
from jobs import GEN, map_jobs, seed_jobs
from screening import prepared_record


def one(job):
    from plant.calibration import residuals as res
    from plant.calibration import loop
    gen, seed = job
    rec, _, prep = prepared_record(gen, seed)
    u = res.reversal_units(prep.q_dec, prep.position_resolution)
    n_units = int(u[0][-1]) + 1 if u is not None and u[0] is not None else 0
    cfg = loop.LoopConfig()
    need = loop.min_events(cfg.family_alpha, loop.FAMILY_CANDIDATES * cfg.max_effects) + loop.UNIT_SPARE
    return {"generator": gen, "seed": seed, "hidden": list(rec.hidden), "n_turning_points": u[1] if u is not None else None,
            "n_units": n_units, "acts": n_units >= need}


if __name__ == "__main__":
    out = map_jobs(one, seed_jobs(sys.argv[2:]))
    json.dump(out, open(sys.argv[1], "w"), indent=0)
    for gen in GEN:
        rs = [r for r in out if r["generator"] == gen]
        if rs:
            print(gen, len(rs), "records,", sum(r["acts"] for r in rs), "with enough reversal units")
