import sys, os, json
sys.path.insert(0, os.getcwd())
from concurrent.futures import ProcessPoolExecutor
def one(arg):
    import tempfile, pathlib
    seed, _, hid = arg.partition(":")
    from plant.calibration.bench_records import make_record
    from plant.calibration.fit import prepare
    from plant.calibration.io import load_record
    from plant.calibration import loop
    r = make_record(int(seed), tuple(hid.split(",")) if hid else ())
    d = pathlib.Path(tempfile.mkdtemp()); r.write_csv(d / "r.csv")
    prep = prepare(load_record(d / "r.csv"))
    K = r.meta.get("two_mass", {}).get("stiffness_nm_rad")
    cfg = loop.LoopConfig(gear_stiffness=K)
    with_rule = [a.kind for a in loop.run_loop(prep, cfg=cfg).accepted]
    orig = loop._viscous_split_predicts
    loop._viscous_split_predicts = lambda *a, **k: None
    without = [a.kind for a in loop.run_loop(prep, cfg=cfg).accepted]
    loop._viscous_split_predicts = orig
    return arg, list(r.hidden), r.meta.get("trajectory"), with_rule, without
if __name__ == "__main__":
    with ProcessPoolExecutor(2) as ex:
        for o in ex.map(one, sys.argv[1:]):
            print(*o, flush=True)
