"""Session 35 filter: which records can the 'gap above the band' change touch? Two-mass records with a
declared stiffness whose lowest possible spring mode sqrt(K/J)/pi (J: the loop's baseline inertia) lies
above the fit's band. Run from the change's tree. Usage: python band_filter.py OUT.json GEN:LO-HI ..."""
import sys, os, json, importlib, tempfile, pathlib
from concurrent.futures import ProcessPoolExecutor
sys.path.insert(0, os.getcwd())
GEN = {"independent": "plant.calibration.bench_records", "blind": "plant.calibration.blind_records"}


def one(job):
    gen, s = job
    from plant.calibration.fit import prepare
    from plant.calibration.io import load_record
    from plant.calibration.loop import fit_baseline, fit_band_hz, spring_mode_floor_hz
    r = importlib.import_module(GEN[gen]).make_record(s)
    K = r.meta.get("two_mass", {}).get("stiffness_nm_rad")
    if K is None:
        return gen, s, None, None, None, False
    d = pathlib.Path(tempfile.mkdtemp()); r.write_csv(d / "r.csv")
    prep = prepare(load_record(d / "r.csv"))
    base, _ = fit_baseline(prep)
    f_min = spring_mode_floor_hz(K, base.param("inertia"))
    band = fit_band_hz(prep)
    return gen, s, K, f_min, band, bool(f_min is not None and f_min > band)


if __name__ == "__main__":
    jobs = []
    for spec in sys.argv[2:]:
        gen, rng = spec.split(":"); lo, hi = map(int, rng.split("-"))
        jobs += [(gen, s) for s in range(lo, hi + 1)]
    with ProcessPoolExecutor(2) as ex:
        out = list(ex.map(one, jobs, chunksize=8))
    json.dump(out, open(sys.argv[1], "w"), indent=0)
    for g in sorted({o[0] for o in out}):
        print(g, "two-mass", sum(1 for o in out if o[0] == g and o[2] is not None),
              "above band", [o[1] for o in out if o[0] == g and o[5]])
