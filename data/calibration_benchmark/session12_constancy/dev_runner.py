"""Session 12 experiment: dev seeds in-process, report per record (hidden, named, log lines with constancy)."""
import json, sys, time, os
from concurrent.futures import ProcessPoolExecutor
sys.path.insert(0, os.getcwd())

def one(seed):
    import tempfile, pathlib
    if os.environ.get("PATCH"):  # session 14: a prototype module that patches the fit (e.g. cls_not_kept.py)
        import importlib.util
        spec = importlib.util.spec_from_file_location("patch", os.environ["PATCH"])
        spec.loader.exec_module(importlib.util.module_from_spec(spec))
    from plant.calibration.bench_records import make_record
    from plant.calibration.report import calibrate
    r = make_record(seed)
    d = pathlib.Path(tempfile.mkdtemp(prefix=f"dev{seed}_"))
    r.write_csv(d / "rec.csv")
    t0 = time.time()
    rep = calibrate(str(d / "rec.csv"), str(d / "out"), plots=False)
    rj = json.loads((d / "out" / "report.json").read_text())
    return {"seed": seed, "hidden": list(r.hidden), "named": [e["kind"] for e in rep["effects"]],
            "unexplained": [u.get("kind") or u.get("domain") for u in rep["unexplained"]],
            "log": [l for l in rj.get("log", []) if "constancy" in l or "add " in l or "wins" in l],
            "rejected": [x for x in rj.get("rejected", []) if "jackknife" in x.get("reason", "")],
            "wall_s": time.time() - t0}

if __name__ == "__main__":
    seeds = [int(x) for x in sys.argv[2:]] if len(sys.argv) > 2 else list(range(1000, 1060))
    out = []
    with ProcessPoolExecutor(2) as ex:
        for res in ex.map(one, seeds):
            out.append(res); print(res["seed"], res["hidden"], res["named"], f"{res['wall_s']:.0f}s", flush=True)
    json.dump(out, open(sys.argv[1], "w"), indent=1)
