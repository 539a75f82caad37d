import sys, os, time, tempfile, importlib
sys.path.insert(0, os.getcwd())
from plant.calibration import loop
from plant.calibration.report import calibrate
GEN = {"independent": "plant.calibration.bench_records", "blind": "plant.calibration.blind_records"}
tot = [0.0, 0]
orig = loop._static_refusals
def timed(*a, **k):
    t = time.perf_counter(); r = orig(*a, **k); tot[0] += time.perf_counter() - t; tot[1] += 1; return r
loop._static_refusals = timed
for gen, seed in [("independent", s) for s in (0, 5, 11, 17, 31)] + [("blind", s) for s in (20487, 20531)]:
    rec = importlib.import_module(GEN[gen]).make_record(seed)
    d = tempfile.mkdtemp(); rec.write_csv(d + "/r.csv")
    tot[:] = [0.0, 0]
    t = time.process_time(); calibrate(d + "/r.csv", d + "/o", plots=False); T = time.process_time() - t
    print(gen, seed, f"calibrate {T:.2f} s CPU; _static_refusals {tot[0]:.3f} s over {tot[1]} calls ({100*tot[0]/T:.1f} %)", flush=True)
