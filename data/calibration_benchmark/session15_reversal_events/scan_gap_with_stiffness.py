import sys, os, tempfile, pathlib
from concurrent.futures import ProcessPoolExecutor
sys.path.insert(0, "/work/main")
def one(seed):
    from plant.calibration.bench_records import make_record
    from plant.calibration.fit import prepare
    from plant.calibration.io import load_record
    from plant.calibration.loop import run_loop, backlash_gap, friction_levels
    r = make_record(seed, ("backlash",))
    d = pathlib.Path(tempfile.mkdtemp()); r.write_csv(d / "r.csv")
    res = run_loop(prepare(load_record(d / "r.csv")))
    b = r.truth["backlash"]["width_rad"]; k = r.meta["two_mass"]["stiffness_nm_rad"]
    W = res.final.spec.backlash_width if "backlash" in [a.kind for a in res.accepted] else None
    if W is None: return (seed, r.meta["trajectory"], [a.kind for a in res.accepted], None, None)
    g = backlash_gap(W, *friction_levels(res.final), k)
    return (seed, r.meta["trajectory"], [a.kind for a in res.accepted], W / b - 1, g / b - 1)
with ProcessPoolExecutor(2) as ex:
    for o in ex.map(one, range(int(sys.argv[1]), int(sys.argv[2]))):
        print(o, flush=True)
