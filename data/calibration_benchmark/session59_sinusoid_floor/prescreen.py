import sys, os, importlib, tempfile, pathlib
sys.path.insert(0, os.getcwd())
from plant.calibration import loop
from plant.calibration.fit import prepare
from plant.calibration.report import load_record
from concurrent.futures import ProcessPoolExecutor
GEN = {"independent": "plant.calibration.bench_records", "blind": "plant.calibration.blind_records"}
def one(job):
    gen, seed = job
    r = importlib.import_module(GEN[gen]).make_record(seed)
    d = pathlib.Path(tempfile.mkdtemp()); r.write_csv(d / "rec.csv")
    prep = prepare(load_record(str(d / "rec.csv")))
    t, v, v0, var, dt = loop._velocity_rows(prep)
    old = loop._periodic_search(t, v, v0, var, dt, loop.PERIODIC_MIN_CYCLES, loop.PERIODIC_MAX_HARMONICS)[:3]
    if old[0] is None:
        old = loop._periodic_search(t, v, v0, var, dt, loop.PERIODIC_MIN_CYCLES_SINUSOID, loop.PHASE_HARMONICS)[:3]
    new = loop.periodic_motion(prep)
    ti = r.meta.get("trajectory_info") or {}
    true_f = 1.0 / ti["period_s"] if isinstance(ti, dict) and ti.get("period_s") else None
    return gen, seed, r.meta.get("trajectory"), true_f, old, new, list(r.hidden)
jobs = [(g, s) for g in ("independent", "blind") for s in range(int(sys.argv[1]), int(sys.argv[2]))]
with ProcessPoolExecutor(2) as ex:
    n = 0
    for gen, seed, tr, tf, old, new, hid in ex.map(one, jobs):
        if old[0] != new[0]:
            n += 1
            print(gen, seed, tr, hid, "true", tf and round(tf, 5), "old", old[0] and round(old[0], 5), round(old[1], 3), old[2], "new", new[0] and round(new[0], 5), round(new[1], 4), new[2], flush=True)
    print("changed", n, "of", len(jobs))
