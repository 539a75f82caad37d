"""Session 15 probe (no code change): per-reversal held-out gains of the reversal candidates.

For every record, the loop runs as in main; each time a reversal candidate (pre-sliding, backlash)
is evaluated, the per-sample CV loss difference d = e0² − e1² is summed over "reversal segments":
the record cut at the midpoints between consecutive velocity reversals, so each segment holds one
reversal and the motion around it. Prints/writes per candidate: step, kind, gain, rank z, number of
reversals, segment sums normalised by the current model's loss, and a one-sided t statistic.
Usage: python probe.py OUT.json SEEDS...
"""
import json, math, os, sys
from concurrent.futures import ProcessPoolExecutor
import numpy as np
sys.path.insert(0, os.getcwd())


def one(seed):
    from plant.calibration import loop as L
    from plant.calibration.bench_records import make_record
    from plant.calibration.fit import prepare
    import tempfile, pathlib
    from plant.calibration.io import load_record
    r = make_record(seed)
    d = pathlib.Path(tempfile.mkdtemp(prefix=f"p15_{seed}_"))
    r.write_csv(d / "rec.csv")
    prep = prepare(load_record(d / "rec.csv"))
    from plant.calibration.residuals import reversal_indices
    rev = np.array([k for k, _ in reversal_indices(prep.dq_dec)], int)
    n = prep.y_dec.size
    cuts = np.r_[0, ((rev[:-1] + rev[1:]) // 2) if rev.size > 1 else np.array([], int), n]
    out = []
    orig = getattr(L, "_evaluate_orig", L._evaluate)   # a worker runs many seeds: wrap the original once
    L._evaluate_orig = orig
    step = {"k": 0}

    def ev(prep_, c, loss_cur, cfg):
        orig(prep_, c, loss_cur, cfg)
        if c.get("group") == "reversal":
            d = loss_cur**2 - c["loss"]**2
            m0 = float(np.mean(loss_cur**2))
            seg = np.add.reduceat(d, cuts[:-1]) / (m0 * n) * 100 if rev.size else np.array([])
            seg_sizes = np.diff(cuts)
            k = seg.size
            t = float(seg.mean() / (seg.std(ddof=1) / math.sqrt(k))) if k >= 2 and seg.std(ddof=1) > 0 else float("nan")
            out.append({"kind": c["kind"], "gain": c["cv_gain_pct"], "z": c["cv_z"], "n_rev": int(rev.size),
                        "seg_pct": [round(float(x), 3) for x in seg], "seg_n": seg_sizes.tolist(), "t": t,
                        "width_or_k": (c["fit"].spec.backlash_width, c["fit"].spec.presliding_k)})
    L._evaluate = ev
    res = L.run_loop(prep)
    return {"seed": seed, "hidden": list(r.hidden), "named": [a.kind for a in res.accepted], "cands": out,
            "log": res.log}


if __name__ == "__main__":
    seeds = [int(x) for x in sys.argv[2:]]
    outs = []
    with ProcessPoolExecutor(2) as ex:
        for o in ex.map(one, seeds):
            outs.append(o)
            first = {}
            for c in o["cands"]:
                first.setdefault(c["kind"], c)
            print(o["seed"], o["hidden"], o["named"], " | ".join(
                f"{k} g={c['gain']:.1f} z={c['z']:.1f} nrev={c['n_rev']} t={c['t']:.2f} segs={c['seg_pct'][:12]}" for k, c in first.items()), flush=True)
    json.dump(outs, open(sys.argv[1], "w"), indent=1)
