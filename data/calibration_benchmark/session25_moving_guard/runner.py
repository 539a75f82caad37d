"""Session 24 runner: records of either generator through `calibrate`, declaring the drive's stiffness
for two-mass records exactly as `schmidt-fil benchmark-calibration` does. Output as session 20's runner.
Usage (from the tree whose loop is to be run): python runner.py OUT.json GENERATOR SEED[:hidden,...] ...
GENERATOR: independent | blind.
"""
import json, os, sys, time
from concurrent.futures import ProcessPoolExecutor
sys.path.insert(0, os.getcwd())

GEN = {"independent": "plant.calibration.bench_records", "blind": "plant.calibration.blind_records"}


def calibrate_record(gen, arg):
    """Generate ``SEED[:hidden,...]`` with generator ``gen``, calibrate it as the benchmark does (the
    stiffness of a two-mass record declared); returns (generator module, record, report, wall s)."""
    import importlib, tempfile, pathlib
    from plant.calibration.report import calibrate
    mod = importlib.import_module(GEN[gen])
    seed, _, hid = arg.partition(":")
    r = mod.make_record(int(seed), tuple(hid.split(",")) if hid else None)
    d = pathlib.Path(tempfile.mkdtemp(prefix=f"s24_{gen}_{seed}_"))
    r.write_csv(d / "rec.csv")
    K = r.meta.get("two_mass", {}).get("stiffness_nm_rad")
    t0 = time.time()
    rep = calibrate(str(d / "rec.csv"), str(d / "out"), plots=False, gear_stiffness=K)
    return mod, r, rep, time.time() - t0


def one(job):
    gen, arg = job
    mod, r, rep, wall = calibrate_record(gen, arg)
    seed = arg.partition(":")[0]
    K = r.meta.get("two_mass", {}).get("stiffness_nm_rad")
    tw = r.truth.get("backlash", {}).get("width_rad")
    bl = [e for e in rep["effects"] if e["kind"] == "backlash"]
    werr = gerr = None
    if bl and tw:
        werr = bl[0]["params"]["width_rad"] / tw - 1
        gerr = bl[0]["gap_rad"] / tw - 1 if "gap_rad" in bl[0] else None
    lib = set(mod.LIBRARY_KINDS)
    named = [e["kind"] for e in rep["effects"]]
    return {"arg": arg, "generator": gen, "seed": int(seed), "hidden": list(r.hidden), "named": named,
            "exact": set(named) == {h for h in r.hidden if h in lib},
            "unexplained": [u.get("kind") or u.get("domain") for u in rep["unexplained"]],
            "undecided": [u["kind"] for u in rep.get("undecided", [])], "K": K,
            "width_err": werr, "gap_err": gerr, "wall_s": wall}


if __name__ == "__main__":
    gen = sys.argv[2]
    out = []
    with ProcessPoolExecutor(2) as ex:
        for o in ex.map(one, [(gen, a) for a in sys.argv[3:]]):
            out.append(o)
            print(o["arg"], o["hidden"], o["named"], "OK " if o["exact"] else "BAD", "und", o["undecided"],
                  f"werr={o['width_err']}", f"gerr={o['gap_err']}", f"{o['wall_s']:.0f}s", flush=True)
    json.dump(out, open(sys.argv[1], "w"), indent=1)
    print("exact", sum(o["exact"] for o in out), "/", len(out))
