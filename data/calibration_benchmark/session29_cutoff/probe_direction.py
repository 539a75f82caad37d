"""Session 29 probe (not a bar): does a named position line depend on the direction of motion?

For every position_periodic term of the final model: the held-out gain of the line itself (final
model against the final model without it) and the gain of splitting it by direction (final model
against the final model plus the line's sin/cos active only while dq > 0). Usage:
python probe_direction.py independent|blind SEED ... [--n N]
"""
import sys, copy
sys.path.insert(0, "/work/main")
import numpy as np
import plant.calibration.fit as F
import plant.calibration.loop as L


def cv_aug(prep, spec, extra_full, k=8):
    names, X = F.design(prep, spec)
    if extra_full is not None:
        X = np.column_stack([X, prep.dec(extra_full)])
        names = names + [f"x{j}" for j in range(extra_full.shape[1])]
    y = prep.y_dec; n = y.size
    edges = np.linspace(0, n, k + 1).astype(int); pred = np.empty(n)
    for a, b in zip(edges[:-1], edges[1:]):
        tr = np.r_[0:a, b:n]
        coef, _ = F._solve(X[tr], y[tr], names)
        pred[a:b] = X[a:b] @ coef
    return y - pred


def main():
    gen = sys.argv[1]
    args = sys.argv[2:]
    n = None
    if "--n" in args:
        i = args.index("--n"); n = int(args[i + 1]); args = args[:i] + args[i + 2:]
    for s in map(int, args):
        if gen == "long":   # session 28's cached 10⁶-sample records of the independent generator
            import json
            from plant.calibration.io import load_record
            meta = json.load(open(f"/tmp/s28_long/long_{s}.json"))
            hidden, rec = meta["hidden"], load_record(f"/tmp/s28_long/long_{s}.csv")
            k = meta["meta"].get("two_mass", {}).get("stiffness_nm_rad")
            prep = F.prepare(rec)
            out = L.run_loop(prep, cfg=L.LoopConfig(gear_stiffness=k))
            report(gen, s, hidden, prep, out)
            continue
        if gen == "independent":
            from plant.calibration.bench_records import make_record
            r = make_record(s, n_samples=n) if n else make_record(s)
        else:
            from plant.calibration.blind_records import make_record
            r = make_record(s)
        hidden = r.hidden
        csv = f"/tmp/s29_probe_{gen}_{s}.csv"
        r.write_csv(csv)
        from plant.calibration.io import load_record
        rec = load_record(csv)
        k = r.meta.get("two_mass", {}).get("stiffness_nm_rad")
        prep = F.prepare(rec)
        out = L.run_loop(prep, cfg=L.LoopConfig(gear_stiffness=k))
        report(gen, s, hidden, prep, out)


def report(gen, s, hidden, prep, out):
        named = [a.kind for a in out.accepted]
        spec = out.final.spec
        for slot, p in enumerate(spec.position_periods):
            x = 2 * np.pi * prep.q / p
            pos = (prep.dq > 0).astype(float)
            split = np.column_stack([np.sin(x) * pos, np.cos(x) * pos])
            e_final = L.cv_losses(prep, spec)
            wo = spec.copy(); wo.position_periods = [pp for j, pp in enumerate(spec.position_periods) if j != slot]
            e_wo = L.cv_losses(prep, wo)
            e_split = cv_aug(prep, spec, split)
            g_line, z_line = L.cv_compare(e_wo, e_final)
            g_split, z_split = L.cv_compare(e_final, e_split)
            frac_pos = float(pos.mean())
            print(f"{gen} {s} hidden={list(hidden)} named={named} period={p:.5g} line gain {g_line:.2f}% z {z_line:.1f} | "
                  f"split gain {g_split:.2f}% z {z_split:.1f} | dq>0 share {frac_pos:.2f}", flush=True)
        if not spec.position_periods:
            print(f"{gen} {s} hidden={list(hidden)} named={named} (no position line)", flush=True)


main()
