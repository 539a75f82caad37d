"""Session 15 probe: is the fitted backlash width the gap b, or the drive's lost motion b + (Fc + Fs)/k?

For each record (backlash-only records ``make_record(seed, ("backlash",))`` and the plan's records
with backlash), the loop runs in-process; where backlash is named its width is compared with the
generator's gap ``b`` and with the lost motion a motor-side encoder sees at a reversal: the gap
plus the gear spring's unwinding of the friction it carried (≈ Fc/k) and its winding up to the
load's breakaway (Fs/k). Usage: python backlash_lost_motion.py OUT.json SEED[:plan] ...
"""
import json, os, sys, tempfile, pathlib
from concurrent.futures import ProcessPoolExecutor
sys.path.insert(0, os.getcwd())


def one(arg):
    from plant.calibration.bench_records import make_record
    from plant.calibration.fit import prepare
    from plant.calibration.io import load_record
    from plant.calibration.loop import run_loop
    seed, plan = (int(arg.split(":")[0]), arg.endswith(":plan"))
    r = make_record(seed) if plan else make_record(seed, ("backlash",))
    d = pathlib.Path(tempfile.mkdtemp(prefix=f"bl{seed}_"))
    r.write_csv(d / "rec.csv")
    res = run_loop(prepare(load_record(d / "rec.csv")))
    m, tm = r.meta, r.meta["two_mass"]
    b = r.truth["backlash"]["width_rad"]
    k = tm["stiffness_nm_rad"]
    lost = b + (m["fc"] + m["fc"] * m["fs_ratio"]) / k
    w = res.final.spec.backlash_width if "backlash" in [a.kind for a in res.accepted] else None
    return {"seed": seed, "plan": plan, "hidden": list(r.hidden), "named": [a.kind for a in res.accepted],
            "trajectory": m["trajectory"], "gap_rad": b, "lost_motion_rad": lost, "fitted_width_rad": w,
            "err_vs_gap": (w / b - 1) if w else None, "err_vs_lost_motion": (w / lost - 1) if w else None,
            "windup_share": 1 - b / lost,
            # the step-fit midpoint: a play operator's switch lands mid-way through each spring ramp
            "half_windup_rad": 0.5 * (b + lost), "err_vs_half_windup": (w / (0.5 * (b + lost)) - 1) if w else None}


if __name__ == "__main__":
    outs = []
    with ProcessPoolExecutor(int(os.environ.get("WORKERS", "1"))) as ex:
        for o in ex.map(one, sys.argv[2:]):
            outs.append(o)
            f = lambda x: "—" if x is None else f"{100 * x:+.0f} %"
            print(o["seed"], "plan" if o["plan"] else "backlash-only", o["trajectory"], o["named"],
                  f"gap {o['gap_rad']:.3g} lost motion {o['lost_motion_rad']:.3g} (wind-up {100 * o['windup_share']:.0f} %) "
                  f"fitted {o['fitted_width_rad'] or float('nan'):.3g}: vs gap {f(o['err_vs_gap'])}, vs lost motion {f(o['err_vs_lost_motion'])}, vs half {f(o['err_vs_half_windup'])}",
                  flush=True)
    json.dump(outs, open(sys.argv[1], "w"), indent=1)
