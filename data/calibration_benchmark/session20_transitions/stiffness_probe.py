"""Session 20 probe (no code change): reversal candidates against the drive's declared stiffness.

For two-mass records (backlash, compliant mode) the generator's stiffness K is what the benchmark
gives the loop (as the engineer would, from the drive's design). For every pre-sliding and backlash
candidate the loop evaluates (the last evaluation of each kind), prints the fitted transition against
the travel the gear spring alone needs: pre-sliding 1/k against 2Fc/K (a spring matched on the
initial slope of the transmitted torque after a reversal), backlash width against (Fc+Ts)/(2K)
(loop.backlash_gap), both in position quanta. Fc, Ts are the candidate fit's friction levels.
Usage: python stiffness_probe.py OUT.json SEED[:hidden,...] ...
"""
import json, math, os, sys
from concurrent.futures import ProcessPoolExecutor
sys.path.insert(0, os.getcwd())


def one(arg):
    from plant.calibration import loop as L
    from plant.calibration.bench_records import make_record
    from plant.calibration.fit import prepare
    from plant.calibration.io import load_record
    import tempfile, pathlib
    seed, _, hid = arg.partition(":")
    r = make_record(int(seed), tuple(hid.split(",")) if hid else None)
    d = pathlib.Path(tempfile.mkdtemp(prefix=f"p20s_{seed}_"))
    r.write_csv(d / "rec.csv")
    prep = prepare(load_record(d / "rec.csv"))
    K = r.meta.get("two_mass", {}).get("stiffness_nm_rad")
    res_q = prep.position_resolution
    out = {}
    orig = getattr(L, "_evaluate_orig", L._evaluate)
    L._evaluate_orig = orig

    def ev(prep_, c, loss_cur, cfg):
        orig(prep_, c, loss_cur, cfg)
        if c.get("group") == "reversal" and K:
            f = c["fit"]
            fc, ts = L.friction_levels(f)
            sp = f.spec
            if sp.presliding_k:
                spring = 2 * fc / K
                out["presliding"] = {"g": c["cv_gain_pct"], "z": c["cv_z"], "disp_q": 1 / sp.presliding_k / res_q,
                                     "spring_q": spring / res_q, "ratio": (1 / sp.presliding_k) / spring,
                                     "bristle_q": (1 / sp.presliding_k - spring) / res_q}
            else:
                gap = L.backlash_gap(sp.backlash_width, fc, ts, K)
                out["backlash"] = {"g": c["cv_gain_pct"], "z": c["cv_z"], "width_q": sp.backlash_width / res_q,
                                   "windup_q": 0.5 * (fc + ts) / K / res_q, "gap_q": gap / res_q}
    L._evaluate = ev
    res = L.run_loop(prep)
    return {"arg": arg, "hidden": list(r.hidden), "named": [a.kind for a in res.accepted], "K": K,
            "truth_width_q": r.truth.get("backlash", {}).get("width_rad", float("nan")) / res_q, "cands": out}


if __name__ == "__main__":
    outs = []
    with ProcessPoolExecutor(2) as ex:
        for o in ex.map(one, sys.argv[2:]):
            outs.append(o)
            print(o["arg"], o["hidden"], o["named"], f"true_gap_q={o['truth_width_q']:.0f}", " | ".join(
                f"{k} " + " ".join(f"{a}={b:.3g}" for a, b in v.items()) for k, v in o["cands"].items()), flush=True)
    json.dump(outs, open(sys.argv[1], "w"), indent=1)
