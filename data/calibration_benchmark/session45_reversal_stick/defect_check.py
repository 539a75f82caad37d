import sys, os, json
sys.path.insert(0, os.getcwd())
sys.path.insert(0, '/work/main/data/calibration_benchmark/session25_sweep_guard')
import runner as base
from concurrent.futures import ProcessPoolExecutor
def one(job):
    gen, seed = job
    mod, r, rep, wall = base.calibrate_record(gen, str(seed))
    hits=[(x['kind'], x['reason'][:80]) for x in rep['rejected'] if 'sticks at its reversals' in x['reason'] and x['kind'] not in ('presliding','backlash')]
    und=[u['kind'] for u in rep.get('undecided',[])]
    return gen, seed, hits
jobs=[]
for a in sys.argv[1:]:
    g, rng = a.split(':'); s=int(rng.split('-')[0]); jobs.append((g,s))
with ProcessPoolExecutor(1) as ex:
    for gen, seed, hits in ex.map(one, jobs):
        print(gen, seed, 'DEFECT' if hits else 'ok', hits, flush=True)
