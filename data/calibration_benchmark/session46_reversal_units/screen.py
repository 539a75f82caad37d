"""Session 46: which records the change can act on, from the record alone (no loop run).

The change tests pre-sliding and backlash candidates on one rank-test unit per reversal where the
record's prepared position has at least ``min_events`` (13) reversal units (the second version: 14,
``loop.UNIT_SPARE``)
(``plant.calibration.residuals.reversal_units``); on every other record the loop computes exactly
what main computes (the named sets; only an undecided entry's reversal count differs). So a decision
runs the change and main on the screened records only. The record is read as `calibrate` reads it:
written to CSV, loaded, prepared.

Usage (repository root, the change's tree): python screen.py OUT.json GEN:LO-HI ...
Output: OUT.json, one entry per record: generator, seed, n_reversals, n_units, acts (bool).
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
    n_units = int(u[0][-1]) + 1 if u is not None else 0
    cfg = loop.LoopConfig()
    # the first version used the units from min_events on; the second (UNIT_SPARE) from one more
    need = loop.min_events(cfg.family_alpha, loop.FAMILY_CANDIDATES * cfg.max_effects) + getattr(loop, "UNIT_SPARE", 0)
    return {"generator": gen, "seed": seed, "hidden": list(rec.hidden), "n_reversals": u[1] if u is not None else None,
            "n_units": n_units, "acts": n_units >= need}


if __name__ == "__main__":
    out = map_jobs(one, seed_jobs(sys.argv[2:]))
    json.dump(out, open(sys.argv[1], "w"), indent=0)
    for gen in GEN:
        rs = [r for r in out if r["generator"] == gen]
        if rs:
            print(gen, len(rs), "records,", sum(r["acts"] for r in rs), "with enough reversal units:",
                  " ".join(f"{gen}:{r['seed']}-{r['seed']}" for r in rs if r["acts"]))
