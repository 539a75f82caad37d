import sys, os, json, importlib, tempfile, pathlib
from concurrent.futures import ProcessPoolExecutor
sys.path.insert(0, os.getcwd())
GEN = {"independent": "plant.calibration.bench_records", "blind": "plant.calibration.blind_records"}
def one(job):
    gen, s = job
    from plant.calibration.fit import prepare
    from plant.calibration.io import load_record
    from plant.calibration.loop import fit_baseline
    r = importlib.import_module(GEN[gen]).make_record(s)
    d = pathlib.Path(tempfile.mkdtemp()); r.write_csv(d / "r.csv")
    _, dec = fit_baseline(prepare(load_record(d / "r.csv")))
    return gen, s, bool(dec["included"])
if __name__ == "__main__":
    jobs = []
    for spec in sys.argv[2:]:
        gen, rng = spec.split(":"); lo, hi = map(int, rng.split("-"))
        jobs += [(gen, s) for s in range(lo, hi + 1)]
    with ProcessPoolExecutor(2) as ex:
        out = list(ex.map(one, jobs))
    json.dump(out, open(sys.argv[1], "w"))
    for g in sorted({o[0] for o in out}):
        print(g, [s for gg, s, inc in out if gg == g and inc])
