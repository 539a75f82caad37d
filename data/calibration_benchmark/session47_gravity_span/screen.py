"""Session 47: which records the change can act on, from the record alone (no loop run).

The change lowers ``loop.GRAVITY_MIN_SPAN_RAD`` from 20° to 10°. The gravity candidate exists only on
rotary records whose span (the loop's own: the prepared, decimated position over its moving samples,
``run_loop``'s ``span``) is at least the floor, so on records spanning under 10° or 20° and more the
change and main compute the same thing. A decision therefore runs both on the screened records only
(records spanning 10–20°). The record is read as `calibrate` reads it: written to CSV, loaded, prepared.

Usage (repository root): python screen.py OUT.json GEN:LO-HI ...
Output: OUT.json, one entry per record: generator, seed, hidden, span_deg, linear, acts (bool).
"""
import math, os, pathlib, sys
import numpy as np
sys.path.insert(0, os.getcwd())
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "tools"))
from screening import prepared_record, run_screen

LO_DEG, HI_DEG = 10.0, 20.0


def one(job):
    from plant.calibration import residuals as res
    gen, seed = job
    rec, loaded, prep = prepared_record(gen, seed)
    mov = res.moving_mask(prep.dq_dec)   # as run_loop computes its span
    span = float(np.ptp(prep.q_dec[mov])) if mov.any() else float(np.ptp(prep.q_dec))
    deg = math.degrees(span)
    return {"generator": gen, "seed": seed, "hidden": list(rec.hidden), "span_deg": deg, "linear": bool(loaded.linear),
            "acts": (not loaded.linear) and LO_DEG <= deg < HI_DEG}


if __name__ == "__main__":
    run_screen(one, sys.argv, __doc__)
