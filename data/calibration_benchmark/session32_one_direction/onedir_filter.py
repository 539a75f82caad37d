import sys, os, json, importlib, tempfile, pathlib
from concurrent.futures import ProcessPoolExecutor
sys.path.insert(0, os.getcwd())
GEN = {"independent": "plant.calibration.bench_records", "blind": "plant.calibration.blind_records"}
def one(job):
    gen, s = job
    import numpy as np
    from plant.calibration.fit import prepare
    from plant.calibration.io import load_record
    from plant.calibration import residuals as res
    r = importlib.import_module(GEN[gen]).make_record(s)
    d = pathlib.Path(tempfile.mkdtemp()); r.write_csv(d / "r.csv")
    p = prepare(load_record(d / "r.csv"))
    mov = res.moving_mask(p.dq_dec)
    return gen, s, int((mov & (p.dq_dec > 0)).sum()), int((mov & (p.dq_dec < 0)).sum()), list(r.hidden)
if __name__ == "__main__":
    jobs = []
    for spec in sys.argv[2:]:
        gen, rng = spec.split(":"); lo, hi = map(int, rng.split("-"))
        jobs += [(gen, s) for s in range(lo, hi + 1)]
    with ProcessPoolExecutor(2) as ex:
        out = list(ex.map(one, jobs))
    json.dump(out, open(sys.argv[1], "w"))
    for o in out:
        if min(o[2], o[3]) < 10: print(*o)
