"""Session 43 probe: session 24's runner keeping the log lines of the own-share probe (`own_share_probe.diff`
applied to the loop). Usage (from the tree whose loop is to be run): python own_share_probe_runner.py OUT.json GEN:LO-HI ..."""
import json, os, sys, pathlib
sys.path.insert(0, os.getcwd())
T = pathlib.Path(__file__).resolve().parents[1]   # data/calibration_benchmark
sys.path.insert(0, str(T / 'session25_sweep_guard')); sys.path.insert(0, str(T / 'tools'))
from jobs import map_jobs, seed_jobs
import runner as base
_cal = base.calibrate_record
def cal(gen, arg):
    mod, r, rep, wall = _cal(gen, arg)
    cal.lines = [l for l in rep.get('log', []) if 'OWNSHARE' in l or ': add ' in l or 'wins' in l]
    return mod, r, rep, wall
base.calibrate_record = cal
def one(job):
    gen, seed = job
    o = base.one((gen, str(seed)))
    o['lines'] = cal.lines
    return o
if __name__ == '__main__':
    out = map_jobs(one, seed_jobs(sys.argv[2:]), chunksize=2)
    json.dump(out, open(sys.argv[1], 'w'), indent=1)
    print('exact', sum(o['exact'] for o in out), '/', len(out))
