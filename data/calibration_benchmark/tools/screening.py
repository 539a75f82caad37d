"""Shared by the sessions' screens (session 46 on): a record read exactly as ``calibrate`` reads it, and
the command-line driver that maps a screen's ``one(job)`` over ``GEN:LO-HI`` arguments.

A screen finds, from the record alone (no loop run), the records a change can act on, so that a
decision runs the change and main on those only. Usage from ``sessionNN_*/screen.py``::

    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "tools"))
    from screening import prepared_record, run_screen
"""
import importlib
import json
import pathlib
import sys
import tempfile

from jobs import GEN, map_jobs, seed_jobs


def prepared_record(gen, seed):
    """Generate record ``seed`` of generator ``gen`` (a :data:`jobs.GEN` key), write it to CSV, load and
    prepare it as ``calibrate`` does; returns (generated record, loaded record, prepared record)."""
    from plant.calibration.fit import prepare
    from plant.calibration.io import load_record
    rec = importlib.import_module(GEN[gen]).make_record(seed)
    with tempfile.TemporaryDirectory() as d:
        rec.write_csv(pathlib.Path(d) / "rec.csv")
        loaded = load_record(pathlib.Path(d) / "rec.csv")
        prep = prepare(loaded)
    return rec, loaded, prep


def run_screen(one, argv, doc):
    """``python screen.py OUT.json GEN:LO-HI ...``: ``one`` over the jobs, OUT.json written, and per
    generator the number of records whose entry has ``acts`` true printed; ``doc`` is the usage text."""
    if len(argv) < 3:
        sys.exit(doc)
    out = map_jobs(one, seed_jobs(argv[2:]))
    json.dump(out, open(argv[1], "w"), indent=0)
    for gen in GEN:
        rs = [o for o in out if o["generator"] == gen]
        print(f"{gen}: {len(rs)} records, the change acts on {sum(o['acts'] for o in rs)}")
    return out
