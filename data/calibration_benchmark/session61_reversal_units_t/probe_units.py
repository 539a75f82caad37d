"""Per-reversal-unit held-out gains of reversal candidates on records with fewer reversals than min_events."""
import sys, os, json, math
sys.path.insert(0, os.getcwd()); sys.path.insert(0, "data/calibration_benchmark/session25_sweep_guard")
import numpy as np
from scipy import stats
import runner
from plant.calibration import loop, residuals as res

CAP = []
_orig_eval = loop._evaluate

def unit_stats(prep, err0, err1):
    t, dq = prep.t_dec, prep.dq_dec
    w = res._window_samples(t, 0.15)
    rev = [k for k, _ in res.reversal_indices(dq) if k - w >= 0 and k + w < dq.size]
    if len(rev) < 2:
        return None
    e0x = getattr(err0, "extrapolated", None); e1x = getattr(err1, "extrapolated", None)
    a0, a1 = np.asarray(err0) ** 2, np.asarray(err1) ** 2
    if e0x is not None and e1x is not None:
        use = ~(e1x & ~e0x)
        a0 = np.where(use, a0, 0.0); a1 = np.where(use, a1, 0.0)
    cuts = [0] + [(a + b) // 2 for a, b in zip(rev[:-1], rev[1:])] + [dq.size]
    L0 = np.add.reduceat(a0, cuts[:-1]); L1 = np.add.reduceat(a1, cuts[:-1])
    # window-only losses ±0.15 s... and ±1 s
    g = 1 - L1 / np.maximum(L0, 1e-300)
    r = np.log(np.maximum(L0, 1e-300) / np.maximum(L1, 1e-300))
    k = len(r)
    tt = float(np.mean(r) / (np.std(r, ddof=1) / math.sqrt(k))) if np.std(r, ddof=1) > 0 else float("inf")
    p = float(stats.t.sf(tt, k - 1))
    return {"k": k, "g": [round(float(x), 4) for x in g], "r": [round(float(x), 4) for x in r], "t": tt, "p": p,
            "z_equiv": float(stats.norm.isf(max(p, 1e-300))), "share_units_pct": 100 * float((L0 - L1).sum() / L0.sum())}

def _evaluate(prep, c, loss_cur, cfg):
    _orig_eval(prep, c, loss_cur, cfg)
    if c.get("group") == "reversal":
        s = unit_stats(prep, loss_cur, c["loss"])
        CAP.append({"kind": c["kind"], "gain": c["cv_gain_pct"], "z": c["cv_z"], "units": s,
                    "n_rev": res.count_reversals(prep.t_dec, prep.dq_dec)})
loop._evaluate = _evaluate

gen, seed = sys.argv[1], sys.argv[2]
mod, record, report, wall = runner.calibrate_record(gen, seed)
out = {"gen": gen, "seed": seed, "hidden": list(record.hidden), "named": [e["kind"] for e in report["effects"]],
       "undecided": report.get("undecided"), "cap": CAP,
       "rejected": [{k: r.get(k) for k in ("kind", "step", "cv_gain_pct", "cv_z", "rules", "reason")} for r in report["rejected"]
                    if r["kind"] in ("presliding", "backlash")]}
json.dump(out, open(os.path.join(sys.argv[3], f"u_{gen}_{seed}.json"), "w"), default=str)
print(gen, seed, wall)
