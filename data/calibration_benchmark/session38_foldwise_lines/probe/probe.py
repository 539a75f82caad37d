"""Session 38 probe (used records only): the loop with and without the fold-wise line choice.
Usage (from the repository root): python probe.py MODE GEN:SEED ...   MODE: main | change
Prints per record: hidden, named, the line candidates' gains and z of step 1."""
import pathlib, sys
sys.path.insert(0, ".")
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "session25_sweep_guard"))
from plant.calibration import loop
from runner import one

mode = sys.argv[1]
if mode == "main":   # the whole record's line choice in every fold (sessions 3-37)
    _ev = loop._evaluate
    loop._evaluate = lambda prep, c, loss_cur, cfg, line_folds=None, ctx=None: _ev(prep, c, loss_cur, cfg)
for arg in sys.argv[2:]:
    gen, seed = arg.split(":")
    o = one((gen, seed))
    print(mode, arg, o["hidden"], o["named"], "OK " if o["exact"] else "BAD", "und", o["undecided"], f"{o['wall_s']:.0f}s", flush=True)
