"""Session 27: the footprint of each hidden library effect in a blind record (see the plan beside).

For each library effect hidden in blind record SEED, the record is simulated again with only that
effect removed (same draws, same trajectory, same noise seed), and the difference of the logged
torques is what the effect put into the record. Its share of the loop's baseline residual, after
what the baseline's own columns absorb, is how much the effect could explain at most.

Usage (from the tree whose loop is used): python footprint.py OUT.json SEED ...
"""
import copy
import json
import math
import os
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, os.getcwd())

#: the bristles of a record without pre-sliding, at the middle of blind_records' draw (0.05-0.6
#: counts at Fs, damping ratio 0.05-0.3) - fixed in the plan
STIFF_COUNTS_AT_FS = 0.325
STIFF_ZETA = 0.175


def _static_load(s):
    """Initial static load and twist exactly as blind_records._draw computes them."""
    tau0 = (s["offset"] + s["a_pp"] * math.sin(2 * math.pi * s["th_load0"] / s["p_pp"] + s["ph_pp"])
            + s["a_g"] * math.sin(s["th_load0"] + s["ph_g"]) + s["a_t"] * math.sin(s["ph_t"]))
    twist0 = 0.0
    if s["two_mass"]:
        twist0 = tau0 / s["k_gear"] + (math.copysign(s["half_b"], tau0) if tau0 != 0.0 else 0.0)
    return tau0, twist0


def without(p, kind):
    """A deep copy of drawn parameters ``p`` with the library effect ``kind`` removed."""
    p = copy.deepcopy(p)
    s = p["_sim"]
    old_twist = s["twist0"]
    if kind == "backlash":
        s["half_b"] = 0.0
    elif kind == "presliding":
        fs_max = max(s["fs_p"], s["fs_n"])
        s["sigma0"] = fs_max / (STIFF_COUNTS_AT_FS * s["q"])
        s["sigma1"] = 2.0 * STIFF_ZETA * math.sqrt(s["sigma0"] * s["jl"])
    elif kind == "asymmetric_friction":
        fc = 0.5 * (s["fc_p"] + s["fc_n"])
        fs_ratio = s["fs_p"] / s["fc_p"]
        fv = p["viscous_nm_s_rad"]
        s.update(fc_p=fc, fc_n=fc, fs_p=fs_ratio * fc, fs_n=fs_ratio * fc, fv_p=fv, fv_n=fv)
    elif kind == "position_periodic":
        s["a_pp"] = 0.0
    elif kind == "gravity_imbalance":
        s["a_g"] = 0.0
    elif kind == "time_periodic":
        s["a_t"] = 0.0
    else:
        raise ValueError(f"not a library kind: {kind}")
    s["tau0"], s["twist0"] = _static_load(s)
    s["th_ref"] = s["th_ref"] - old_twist + s["twist0"]
    return p


def _logged(p):
    from plant.calibration import blind_records as br
    p = copy.deepcopy(p)          # _log writes into p["measurement"]
    sim = br._simulate(p)
    return br._log(p, sim)


def one(seed):
    from plant.calibration import blind_records as br
    from plant.calibration.fit import N_BORDER, design, prepare
    from plant.calibration.io import load_record
    from plant.calibration.loop import LoopConfig, fit_baseline

    hidden = br.plan()[seed % 60]
    lib = [h for h in hidden if h in br.LIBRARY_KINDS]
    if not lib:
        return []
    p = br._draw(seed, hidden)
    t, tq, pos = _logged(p)
    d = Path(tempfile.mkdtemp(prefix=f"s27_fp_{seed}_"))
    br.BlindRecord(seed, hidden, {}, t, tq, pos).write_csv(d / "rec.csv")
    rec = load_record(str(d / "rec.csv"))
    prep = prepare(rec)
    K = p.get("two_mass", {}).get("stiffness_nm_rad")
    base, _ = fit_baseline(prep, LoopConfig(gear_stiffness=K))
    _, X = design(prep, base.spec)
    r = base.residual
    out = []
    for kind in lib:
        t2, tq2, pos2 = _logged(without(p, kind))
        dtau = tq - tq2
        br.BlindRecord(seed, hidden, {}, t2, tq2, pos2).write_csv(d / "cf.csv")
        prep2 = prepare(load_record(str(d / "cf.csv")))
        base2, _ = fit_baseline(prep2, LoopConfig(gear_stiffness=K))
        r2 = base2.residual
        delta = prep.dec(dtau[N_BORDER:])
        coef, *_ = np.linalg.lstsq(X, delta, rcond=None)
        dperp = delta - X @ coef
        row = {
            "seed": seed, "kind": kind, "hidden": list(hidden),
            # the amended measure (see the plan's amendment): the baseline residual the effect adds
            "excess_pct": 100.0 * (1.0 - float(r2 @ r2) / float(r @ r)),
            "share_pct": 100.0 * float(dperp @ dperp) / float(r @ r),
            "raw_share_pct": 100.0 * float(delta @ delta) / float(r @ r),
            "footprint_rms_nm": float(np.sqrt(np.mean(dtau ** 2))),
            "noise_std_nm": p["measurement"]["noise_std_nm"],
            "position_rms_change_rad": float(np.sqrt(np.mean((pos - pos2) ** 2))),
            "n_reversals": p.get("n_reversals"), "trajectory": p.get("trajectory"),
            "chain": p["measurement"]["logged"], "baseline_rel_error_pct": base.relative_error_pct,
        }
        if kind == "backlash":
            s = p["_sim"]
            fc = 0.5 * (s["fc_p"] + s["fc_n"])
            row["windup_over_gap"] = (2 * fc / s["k_gear"]) / (2 * s["half_b"])
        out.append(row)
    return out


if __name__ == "__main__":
    seeds = [int(a) for a in sys.argv[2:]]
    rows = []
    with ProcessPoolExecutor(2) as ex:
        for res in ex.map(one, seeds):
            for o in res:
                rows.append(o)
                print(o["seed"], o["kind"], f"excess {o['excess_pct']:.2f} %", f"share {o['share_pct']:.2f} % (raw {o['raw_share_pct']:.2f} %)",
                      f"rev {o['n_reversals']}", o["trajectory"], o["chain"],
                      f"w/g {o.get('windup_over_gap', float('nan')):.1f}", flush=True)
    json.dump(rows, open(sys.argv[1], "w"), indent=1)
