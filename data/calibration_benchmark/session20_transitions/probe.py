"""Session 20 probe (no code change): where a reversal candidate earns its held-out gain.

For every reversal candidate (pre-sliding, backlash) the loop evaluates, the per-sample CV loss
difference d = e0² − e1² is split into the *transition windows* — decimated samples whose travel
since the last velocity reversal is within the candidate's own transition displacement (pre-sliding:
ln(200)/k, where the bristle state is within 1 % of its sliding value; backlash: the width), widened
by DILATE decimated samples on each side for the decimation filter — and the rest.
Prints/writes per candidate: kind, step, gain %, z, reversals, share of time in the windows,
gain inside and outside (in % of the current model's CV MSE), the rank z of the inside samples alone.
Usage: python probe.py OUT.json SEEDS...
"""
import json, math, os, sys
from concurrent.futures import ProcessPoolExecutor
import numpy as np
sys.path.insert(0, os.getcwd())
DILATE = 3


def windows(prep, D):
    from plant.calibration.residuals import reversal_indices
    q = prep.q_dec
    n = q.size
    rev = [k for k, _ in reversal_indices(prep.dq_dec)]
    inw = np.zeros(n, bool)
    for j, k in enumerate(rev):
        end = rev[j + 1] if j + 1 < len(rev) else n
        trav = np.abs(q[k:end] - q[k])
        far = np.flatnonzero(trav > D)
        stop = k + (int(far[0]) if far.size else end - k)
        inw[max(0, k - DILATE): min(n, stop + DILATE)] = True
    return inw, len(rev)


def one(seed):
    from plant.calibration import loop as L
    from plant.calibration.bench_records import make_record
    from plant.calibration.fit import prepare
    import tempfile, pathlib
    from plant.calibration.io import load_record
    r = make_record(seed)
    d = pathlib.Path(tempfile.mkdtemp(prefix=f"p20_{seed}_"))
    r.write_csv(d / "rec.csv")
    prep = prepare(load_record(d / "rec.csv"))
    out = []
    orig = getattr(L, "_evaluate_orig", L._evaluate)
    L._evaluate_orig = orig

    def ev(prep_, c, loss_cur, cfg):
        orig(prep_, c, loss_cur, cfg)
        if c.get("group") == "reversal":
            sp = c["fit"].spec
            D = math.log(200.0) / sp.presliding_k if sp.presliding_k else sp.backlash_width
            inw, nrev = windows(prep_, D)
            dd = loss_cur**2 - c["loss"]**2
            m0 = float(np.mean(loss_cur**2)) * dd.size
            g_in = 100 * float(dd[inw].sum()) / m0
            g_out = 100 * float(dd[~inw].sum()) / m0
            z_in = L.cv_compare(loss_cur[inw], c["loss"][inw])[1] if inw.sum() > 125 else float("nan")
            out.append({"kind": c["kind"], "gain": c["cv_gain_pct"], "z": c["cv_z"], "n_rev": nrev,
                        "D": D, "time_in_pct": 100 * float(inw.mean()), "g_in": g_in, "g_out": g_out, "z_in": z_in,
                        "quanta": D / prep_.position_resolution})
    L._evaluate = ev
    res = L.run_loop(prep)
    return {"seed": seed, "hidden": list(r.hidden), "traj": r.trajectory if hasattr(r, "trajectory") else None,
            "named": [a.kind for a in res.accepted], "cands": out}


if __name__ == "__main__":
    seeds = [int(x) for x in sys.argv[2:]]
    outs = []
    with ProcessPoolExecutor(2) as ex:
        for o in ex.map(one, seeds):
            outs.append(o)
            last = {}
            for c in o["cands"]:
                last[c["kind"]] = c  # the last evaluation of each kind (the one that was accepted, if any)
            print(o["seed"], o["hidden"], o["named"], " | ".join(
                f"{k} g={c['gain']:.1f} z={c['z']:.1f} nrev={c['n_rev']} tin={c['time_in_pct']:.0f}% gin={c['g_in']:.2f} gout={c['g_out']:.2f} zin={c['z_in']:.1f} q={c['quanta']:.0f}"
                for k, c in last.items()), flush=True)
    json.dump(outs, open(sys.argv[1], "w"), indent=1)
