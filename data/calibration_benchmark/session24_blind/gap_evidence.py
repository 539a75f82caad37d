"""Session 24 probe: for records where the gap-inside-the-spring candidate is named, its gain over the
declared spring alone (CV, %), the z of that comparison, the reversals, the gap against the wind-up.
Usage: python gap_evidence.py OUT.json GENERATOR SEED[:hidden] ...  (run from the tree to probe)"""
import json, os, sys
from concurrent.futures import ProcessPoolExecutor
sys.path.insert(0, os.getcwd())
GEN = {"independent": "plant.calibration.bench_records", "blind": "plant.calibration.blind_records"}


def one(job):
    gen, arg = job
    import importlib, tempfile, pathlib, re
    from plant.calibration.report import calibrate
    mod = importlib.import_module(GEN[gen])
    seed, _, hid = arg.partition(":")
    r = mod.make_record(int(seed), tuple(hid.split(",")) if hid else None)
    d = pathlib.Path(tempfile.mkdtemp(prefix=f"s24g_{seed}_"))
    r.write_csv(d / "rec.csv")
    K = r.meta.get("two_mass", {}).get("stiffness_nm_rad")
    rep = calibrate(str(d / "rec.csv"), str(d / "out"), plots=False, gear_stiffness=K)
    out = {"arg": arg, "hidden": list(r.hidden), "named": [e["kind"] for e in rep["effects"]],
           "truth_gap": r.truth.get("backlash", {}).get("width_rad")}
    for e in rep["effects"]:
        if e["kind"] == "backlash":
            out["gap"] = e["params"]["width_rad"]
            m = re.search(r"wind-up 2Fc/K = ([0-9.eE+-]+)", e["evidence"])
            out["windup"] = float(m.group(1)) if m else None
            m = re.search(r"over the spring[^0-9-]*(-?[0-9.]+) %", e["evidence"])
            out["evidence"] = e["evidence"][-400:]
    out["log_steps"] = [l[:300] for l in rep["log"] if "backlash" in l][:3]
    return out


if __name__ == "__main__":
    gen = sys.argv[2]
    with ProcessPoolExecutor(2) as ex:
        res = list(ex.map(one, [(gen, a) for a in sys.argv[3:]]))
    for o in res:
        print(json.dumps({k: o.get(k) for k in ("arg", "hidden", "named", "truth_gap", "gap", "windup")}))
        print("   ", o.get("evidence"))
    json.dump(res, open(sys.argv[1], "w"), indent=1)
