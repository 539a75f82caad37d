"""Session 20 probe (a patch, not main's code): the declared gear spring in the baseline.

When the drive's stiffness K is declared (the benchmark declares it for its two-mass records, as
an engineer would from the drive's design), the Coulomb column sign(w) of every model without
pre-sliding is replaced by the elasto-plastic (Prandtl stop) operator of the motor position with
the gear's wind-up d = Fc/K, with backlash's gap 2h in the middle: the load q_l = play(q, 2(h + d))
sticks until the spring carries Fc; the transmitted (friction) torque is K·dz(q − q_l, h), normalised
s = dz(q − q_l, h)/d ∈ [−1, 1]: after a reversal the spring unwinds (d), the gap is crossed (2h),
the spring winds up (d). The viscous column uses the load's velocity. Used only when the swing 2Fc/K
is resolved (≥ MIN_TRANSITION_COUNTS quanta); otherwise main's columns. Fc is the plain baseline's Coulomb level
(one fixed value per record; a probe, not a fixed point). Prints the named sets and, per reversal
candidate, the same figures as stiffness_probe.py.
Usage: python spring_baseline_probe.py OUT.json SEED[:hidden,...] ...
"""
import json, os, sys
from concurrent.futures import ProcessPoolExecutor
sys.path.insert(0, os.getcwd())


def one(arg):
    import numpy as np
    from plant.calibration import fit as F
    from plant.calibration import loop as L
    from plant.calibration.bench_records import make_record
    from plant.calibration.io import load_record
    import tempfile, pathlib
    seed, _, hid = arg.partition(":")
    r = make_record(int(seed), tuple(hid.split(",")) if hid else None)
    d = pathlib.Path(tempfile.mkdtemp(prefix=f"p20b_{seed}_"))
    r.write_csv(d / "rec.csv")
    prep = F.prepare(load_record(d / "rec.csv"))
    K = r.meta.get("two_mass", {}).get("stiffness_nm_rad")
    orig_df = getattr(F, "_design_full_orig", F.design_full)
    F._design_full_orig = orig_df
    F.design_full = orig_df
    fc0 = L._coulomb(F.fit_model(prep, F.ModelSpec()))
    if K and fc0 > 0 and 2 * fc0 / K >= L.MIN_TRANSITION_COUNTS * prep.position_resolution:
        dd = fc0 / K

        def df(prep_, spec, q=None, dq=None, ddq=None, t=None):
            names, X = orig_df(prep_, spec, q, dq, ddq, t)
            if spec.presliding_k is None:
                qq = prep_.q if q is None else q
                h = 0.5 * spec.backlash_width if spec.backlash_width is not None else 0.0
                ql = F.play_operator(qq, 2 * (h + dd))       # the load: stuck until the spring carries Fc
                delta = qq - ql
                s = np.where(delta > h, delta - h, np.where(delta < -h, delta + h, 0.0)) / dd
                w = np.gradient(ql, prep_.dt_s)
                col = {"viscous": w, "viscous_pos": np.maximum(w, 0.0), "viscous_neg": np.minimum(w, 0.0),
                       "coulomb": s, "coulomb_pos": np.maximum(s, 0.0), "coulomb_neg": np.minimum(s, 0.0)}
                if spec.stribeck_vs is not None:
                    col["stribeck"] = s * np.exp(-((w / spec.stribeck_vs) ** 2))
                for nm, v in col.items():
                    if nm in names:
                        X[:, names.index(nm)] = v
            return names, X
        F.design_full = df
    out = {}
    orig = getattr(L, "_evaluate_orig", L._evaluate)
    L._evaluate_orig = orig

    def ev(prep_, c, loss_cur, cfg):
        orig(prep_, c, loss_cur, cfg)
        if c.get("group") == "reversal":
            sp = c["fit"].spec
            out[c["kind"]] = {"g": round(c["cv_gain_pct"], 2), "z": round(c["cv_z"], 2),
                              "x_q": round((1 / sp.presliding_k if sp.presliding_k else sp.backlash_width) / prep_.position_resolution, 1)}
    L._evaluate = ev
    res = L.run_loop(prep)
    width = res.final.spec.backlash_width
    tw = r.truth.get("backlash", {}).get("width_rad")
    return {"arg": arg, "hidden": list(r.hidden), "named": [a.kind for a in res.accepted], "K": K,
            "width_err": (width / tw - 1) if (width and tw) else None, "cands": out,
            "base_rel_pct": res.baseline.relative_error_pct}


if __name__ == "__main__":
    outs = []
    with ProcessPoolExecutor(2) as ex:
        for o in ex.map(one, sys.argv[2:]):
            outs.append(o)
            print(o["arg"], o["hidden"], o["named"], f"width_err={o['width_err']}", f"base={o['base_rel_pct']:.2f}%", o["cands"], flush=True)
    json.dump(outs, open(sys.argv[1], "w"), indent=1)
