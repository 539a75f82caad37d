"""Session 32: the gap from main's formula (loop.backlash_gap) against the gap refitted after the loop
(loop.geared_gap), on the same loop run (stiffness declared as the benchmark does). Backlash records.
Usage (from the tree with geared_gap): python gap_compare.py OUT.json GENERATOR SEED[:hidden] ...
"""
import json, os, sys, importlib
from concurrent.futures import ProcessPoolExecutor
sys.path.insert(0, os.getcwd())
GEN = {"independent": "plant.calibration.bench_records", "blind": "plant.calibration.blind_records"}


def one(job):
    import tempfile, pathlib, dataclasses
    gen, arg = job
    from plant.calibration.fit import prepare
    from plant.calibration.io import load_record
    from plant.calibration.loop import LoopConfig, backlash_gap, friction_levels, geared_gap, run_loop
    mod = importlib.import_module(GEN[gen])
    seed, _, hid = arg.partition(":")
    r = mod.make_record(int(seed), tuple(hid.split(",")) if hid else None)
    d = pathlib.Path(tempfile.mkdtemp()); r.write_csv(d / "r.csv")
    K = r.meta.get("two_mass", {}).get("stiffness_nm_rad")
    prep = prepare(load_record(d / "r.csv"))
    res = run_loop(prep, cfg=dataclasses.replace(LoopConfig(), gear_stiffness=K))
    named = [a.kind for a in res.accepted]
    W = res.final.spec.backlash_width
    if W is None or "backlash" not in r.truth or K is None:
        return {"arg": arg, "named": named}
    gap = r.truth["backlash"]["width_rad"]
    fc, ts = friction_levels(res.final)
    g_formula = backlash_gap(W, fc, ts, K)
    g_geared, how = geared_gap(prep, res.final, K)
    return {"arg": arg, "named": named, "traj": r.meta["trajectory"], "true_gap": gap,
            "width_err": W / gap - 1, "formula_err": g_formula / gap - 1,
            "geared_err": (g_geared / gap - 1) if g_geared is not None else None, "swing_over_gap": how["swing"] / gap}


if __name__ == "__main__":
    gen = sys.argv[2]
    out = []
    with ProcessPoolExecutor(2) as ex:
        for o in ex.map(one, [(gen, a) for a in sys.argv[3:]]):
            out.append(o)
            if "true_gap" in o:
                print(o["arg"], o["traj"], o["named"], f"gap {o['true_gap']:.3g}: width {o['width_err']:+.0%}, formula {o['formula_err']:+.0%}, "
                      + (f"geared {o['geared_err']:+.0%}" if o["geared_err"] is not None else "geared n/a"),
                      f"swing/gap {o['swing_over_gap']:.2f}", flush=True)
            else:
                print(o["arg"], o["named"], flush=True)
    json.dump(out, open(sys.argv[1], "w"), indent=1)
    rows = [o for o in out if "true_gap" in o]
    import statistics as st
    f = [abs(o["formula_err"]) for o in rows]
    g = [abs(o["geared_err"] if o["geared_err"] is not None else o["formula_err"]) for o in rows]
    print(f"backlash named on {len(rows)}; formula within 30 %: {sum(x <= 0.3 for x in f)}, median {st.median(f) if f else float('nan'):.1%}; "
          f"refit (formula where n/a) within 30 %: {sum(x <= 0.3 for x in g)}, median {st.median(g) if g else float('nan'):.1%}")
