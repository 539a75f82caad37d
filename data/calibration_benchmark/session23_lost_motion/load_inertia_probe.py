"""Session 23 probe: the load's inertia behind the gap. After main's loop (named sets unchanged),
refit the backlash width with the inertia split into the motor's (ddq) and the load's (the second
derivative of the play output q_l = play(q, W)): inside the gap the motor accelerates alone.
Prints the width's error against the gap, with and without the split, and the fitted inertias
against the generator's J_m, J_l."""
import sys, os, tempfile, pathlib, json, math, dataclasses
from concurrent.futures import ProcessPoolExecutor
import numpy as np
sys.path.insert(0, os.getcwd())
import plant.calibration.fit as F
_orig = F.design_full
SPLIT = {"on": False}
def design_full(prep, spec, q=None, dq=None, ddq=None, t=None):
    names, X = _orig(prep, spec, q, dq, ddq, t)
    if SPLIT["on"] and spec.backlash_width is not None and not spec.geared:
        qq = prep.q if q is None else q
        ql = F.play_operator(qq, spec.backlash_width)
        wl = np.gradient(ql, prep.dt_s)
        ddl = np.gradient(wl, prep.dt_s)
        names = names + ["load_inertia"]
        X = np.column_stack([X, ddl])
    return names, X
F.design_full = design_full

def one(arg):
    seed, hidden = arg
    from plant.calibration.bench_records import make_record
    from plant.calibration.io import load_record
    from plant.calibration.loop import run_loop
    r = make_record(seed, hidden)
    d = pathlib.Path(tempfile.mkdtemp()); r.write_csv(d / "r.csv")
    prep = F.prepare(load_record(d / "r.csv"))
    SPLIT["on"] = False
    res = run_loop(prep)
    named = [a.kind for a in res.accepted]
    out = {"seed": seed, "traj": r.meta["trajectory"], "named": named}
    if "backlash" not in named or res.final.spec.backlash_width is None or "backlash" not in r.truth:
        return out
    b = r.truth["backlash"]["width_rad"]; tm = r.meta["two_mass"]
    W0 = res.final.spec.backlash_width
    SPLIT["on"] = True
    best = None
    for w in np.geomspace(0.2 * W0, 2.0 * W0, 31):
        f = F.fit_model(prep, dataclasses.replace(res.final.spec.copy(), backlash_width=float(w)), refine=False)
        if best is None or f.rss < best.rss:
            best = f
    names = [n for n, _, _ in best.spec.hyper()]
    free = [i for i, n in enumerate(names) if n == "backlash_width"]
    f2 = F.fit_model(prep, best.spec, rel_bounds={i: (0.3 if i in free else 0.0) for i in range(len(names))}, free=free)
    if f2.rss > best.rss:
        f2 = best
    SPLIT["on"] = False
    W1 = f2.spec.backlash_width
    out.update(gap=b, W0=W0, W1=W1, err0=W0 / b - 1, err1=W1 / b - 1, rss_ratio=f2.rss / res.final.rss,
               Jm=tm["J_m"], Jl=tm["J_l"], Jm_fit=f2.param("inertia"), Jl_fit=f2.param("load_inertia"),
               J_fit0=res.final.param("inertia"), wind=(r.meta["fc"] * (1 + r.meta["fs_ratio"])) / (2 * tm["stiffness_nm_rad"]) / b)
    return out

if __name__ == "__main__":
    args = []
    for a in sys.argv[2:]:
        if ":" in a:
            s, h = a.split(":"); args.append((int(s), tuple(h.split("+"))))
        else:
            args.append((int(a), None))
    with ProcessPoolExecutor(2) as ex, open(sys.argv[1], "w") as fo:
        for o in ex.map(one, args):
            fo.write(json.dumps(o) + "\n"); fo.flush()
            if "W1" in o:
                print(o["seed"], o["traj"], o["named"], f"width {o['err0']:+.0%} -> split {o['err1']:+.0%}  rss {o['rss_ratio']:.3f}  "
                      f"J {o['J_fit0']:.3g} vs {o['Jm']+o['Jl']:.3g}; Jm {o['Jm_fit']:.3g} vs {o['Jm']:.3g}, Jl {o['Jl_fit']:.3g} vs {o['Jl']:.3g}; wind/gap {o['wind']:.2f}", flush=True)
            else:
                print(o["seed"], o["traj"], o["named"], flush=True)
