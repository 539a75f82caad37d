import sys, os, json
sys.path.insert(0, os.getcwd()); sys.path.insert(0, "data/calibration_benchmark/session25_sweep_guard")
import runner
from plant.calibration import loop
orig = loop._beats_out_of_library
CALLS = []
def wrap(prep, c, cands, zc, cfg):
    r = orig(prep, c, cands, zc, cfg)
    if c.get("beside_out_of_library"): CALLS.append(f"{c['kind']} {c['cv_gain_pct']:.1f}/{c['cv_z']:.1f} vs {[(o['kind'], round(o['cv_gain_pct'],1)) for o in cands if o.get('group')=='out-of-library']} -> {c.get('beside_out_of_library')} {'REFUSED' if r else 'kept'}")
    return r
loop._beats_out_of_library = wrap
for arg in sys.argv[2:]:
    CALLS.clear()
    mod, r, rep, wall = runner.calibrate_record(sys.argv[1], arg)
    print(arg, list(r.hidden), [e["kind"] for e in rep["effects"]], [u.get("kind") or u.get("domain") for u in rep["unexplained"]], "|", "; ".join(CALLS) if CALLS else "-", flush=True)
