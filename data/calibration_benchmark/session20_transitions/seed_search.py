import sys, os, tempfile, pathlib, dataclasses
sys.path.insert(0, os.getcwd())
from plant.calibration.bench_records import make_record
from plant.calibration.fit import prepare
from plant.calibration.io import load_record
from plant.calibration.loop import run_loop, LoopConfig
kind = sys.argv[1]
for seed in range(int(sys.argv[2]), int(sys.argv[3])):
    r = make_record(seed, (kind,))
    d = pathlib.Path(tempfile.mkdtemp()); r.write_csv(d / "r.csv")
    prep = prepare(load_record(d / "r.csv"))
    K = r.meta["two_mass"]["stiffness_nm_rad"]
    a = [x.kind for x in run_loop(prep).accepted]
    b_res = run_loop(prep, cfg=LoopConfig(gear_stiffness=K))
    b = [x.kind for x in b_res.accepted]
    why = [x["reason"][:60] for x in b_res.rejected if "gear spring" in x["reason"]]
    print(seed, r.meta["trajectory"], len(r.t) if hasattr(r, "t") else "", "noK", a, "K", b, why[:1], flush=True)
