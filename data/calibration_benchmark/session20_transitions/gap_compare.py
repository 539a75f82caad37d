"""Session 20: the gap from main's formula (loop.backlash_gap, session 15) against the gap refitted
with the declared spring (loop.geared_gap), on the same loop result. Backlash records only.
Usage: python gap_compare.py OUT.json SEED[:hidden] ...
"""
import json, os, sys
from concurrent.futures import ProcessPoolExecutor
sys.path.insert(0, os.getcwd())


def one(arg):
    import tempfile, pathlib
    from plant.calibration.bench_records import make_record
    from plant.calibration.fit import prepare
    from plant.calibration.io import load_record
    from plant.calibration.loop import backlash_gap, friction_levels, geared_gap, run_loop
    seed, _, hid = arg.partition(":")
    r = make_record(int(seed), tuple(hid.split(",")) if hid else None)
    d = pathlib.Path(tempfile.mkdtemp()); r.write_csv(d / "r.csv")
    prep = prepare(load_record(d / "r.csv"))
    res = run_loop(prep)
    named = [a.kind for a in res.accepted]
    W = res.final.spec.backlash_width
    if W is None or "backlash" not in r.truth:
        return {"arg": arg, "named": named}
    gap = r.truth["backlash"]["width_rad"]
    K = r.meta["two_mass"]["stiffness_nm_rad"]
    fc, ts = friction_levels(res.final)
    g_formula = backlash_gap(W, fc, ts, K)
    g_geared, how = geared_gap(prep, res.final, K)
    return {"arg": arg, "named": named, "traj": r.meta["trajectory"], "true_gap": gap,
            "width_err": W / gap - 1, "formula_err": g_formula / gap - 1,
            "geared_err": (g_geared / gap - 1) if g_geared is not None else None, "swing_over_gap": how["swing"] / gap}


if __name__ == "__main__":
    out = []
    with ProcessPoolExecutor(2) as ex:
        for o in ex.map(one, sys.argv[2:]):
            out.append(o)
            if "true_gap" in o:
                print(o["arg"], o["traj"], o["named"], f"gap {o['true_gap']:.3g}: width {o['width_err']:+.0%}, formula {o['formula_err']:+.0%}, "
                      f"geared {o['geared_err']:+.0%}" if o["geared_err"] is not None else "geared n/a", f"swing/gap {o['swing_over_gap']:.2f}", flush=True)
            else:
                print(o["arg"], o["named"], flush=True)
    json.dump(out, open(sys.argv[1], "w"), indent=1)
