import sys, os, json
sys.path.insert(0, os.getcwd()); sys.path.insert(0, "data/calibration_benchmark/session25_sweep_guard")
import runner
from concurrent.futures import ProcessPoolExecutor
def one(job):
    gen, arg = job
    mod, r, rep, wall = runner.calibrate_record(gen, arg)
    hits = [f"{c['kind']} s{c['step']} {c['cv_gain_pct']:.1f}% z{c['cv_z']:.1f}: {c['reason'][:200]}" for c in rep["rejected"] if "out-of-library description" in c["reason"]]
    return f"{gen} {arg} hidden {list(r.hidden)} named {[e['kind'] for e in rep['effects']]} ool {[u.get('kind') or u.get('domain') for u in rep['unexplained']]} {wall:.0f}s\n  " + "\n  ".join(hits)
jobs = [a.split("/") for a in sys.argv[1:]]
with ProcessPoolExecutor(2) as ex:
    for o in ex.map(one, jobs): print(o, flush=True)
