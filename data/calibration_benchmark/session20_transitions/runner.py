"""Session 20 runner: records of the independent generator through `calibrate`, declaring the drive's
stiffness for two-mass records exactly as `schmidt-fil benchmark-calibration` does
(host/calibration_benchmark.py). Writes hidden, named, backlash width and gap errors per record.
Usage: python runner.py OUT.json SEED[:hidden,...] ...
"""
import json, os, sys, time
from concurrent.futures import ProcessPoolExecutor
sys.path.insert(0, os.getcwd())


def one(arg):
    import tempfile, pathlib
    from plant.calibration.bench_records import make_record
    from plant.calibration.report import calibrate
    seed, _, hid = arg.partition(":")
    r = make_record(int(seed), tuple(hid.split(",")) if hid else None)
    d = pathlib.Path(tempfile.mkdtemp(prefix=f"s20_{seed}_"))
    r.write_csv(d / "rec.csv")
    K = r.meta.get("two_mass", {}).get("stiffness_nm_rad")
    t0 = time.time()
    rep = calibrate(str(d / "rec.csv"), str(d / "out"), plots=False, gear_stiffness=K)
    tw = r.truth.get("backlash", {}).get("width_rad")
    bl = [e for e in rep["effects"] if e["kind"] == "backlash"]
    werr = gerr = None
    if bl and tw:
        werr = bl[0]["params"]["width_rad"] / tw - 1
        gerr = bl[0]["gap_rad"] / tw - 1 if "gap_rad" in bl[0] else None
    return {"arg": arg, "seed": int(seed), "hidden": list(r.hidden), "named": [e["kind"] for e in rep["effects"]],
            "unexplained": [u.get("kind") or u.get("domain") for u in rep["unexplained"]],
            "undecided": [u["kind"] for u in rep.get("undecided", [])], "K": K,
            "gear_spring": rep["stribeck"].get("gear_spring"), "width_err": werr, "gap_err": gerr,
            "wall_s": time.time() - t0}


if __name__ == "__main__":
    out = []
    with ProcessPoolExecutor(2) as ex:
        for o in ex.map(one, sys.argv[2:]):
            out.append(o)
            gs = o["gear_spring"] or {}
            print(o["arg"], o["hidden"], o["named"], "und", o["undecided"], f"spring={gs.get('used')}",
                  f"werr={o['width_err']}", f"gerr={o['gap_err']}", f"{o['wall_s']:.0f}s", flush=True)
    json.dump(out, open(sys.argv[1], "w"), indent=1)
