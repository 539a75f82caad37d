"""Session 15 probe: does a play followed by a bristle-like compliance separate the gap from the wind-up?

Session 13 fitted the play output through the pre-sliding state (a compliant play) and found it
worse on 10 of 11 records, but its grid started at 10 position quanta and could not reach the
rigid limit. Here, on records where the loop names backlash, the final model's play is refitted
with a compliance whose displacement grid runs from 0.1 quantum (the rigid limit) to the width;
the best grid point is refined jointly with the width. Printed: width of the play alone and of the
compliant play against the generator's gap, and the RSS ratio (compliant / play).
Usage: python compliant_play_probe.py OUT.json SEED...   (backlash-only records)
"""
import dataclasses, json, math, os, sys, tempfile, pathlib
from concurrent.futures import ProcessPoolExecutor
import numpy as np
sys.path.insert(0, os.getcwd())


def one(seed, mesh=False):
    """``mesh``: the grid of compliant_mesh_probe.py (d up to half the width, the gap b = width − 2d);
    that script installs its design_full before the workers start."""
    from plant.calibration.bench_records import make_record
    from plant.calibration.fit import fit_model, prepare
    from plant.calibration.io import load_record
    from plant.calibration.loop import run_loop
    r = make_record(seed, ("backlash",))
    d = pathlib.Path(tempfile.mkdtemp()); r.write_csv(d / "r.csv")
    prep = prepare(load_record(d / "r.csv"))
    res = run_loop(prep)
    b = r.truth["backlash"]["width_rad"]
    if "backlash" not in [a.kind for a in res.accepted] or res.final.spec.presliding_k is not None:
        return {"seed": seed, "named": [a.kind for a in res.accepted]}
    W = res.final.spec.backlash_width
    q = prep.position_resolution
    best = None
    for disp in np.logspace(math.log10(0.1 * q), math.log10(0.5 * W if mesh else W), 12):
        s = dataclasses.replace(res.final.spec.copy(), presliding_k=1.0 / disp,
                                backlash_width=max(W - 2 * disp, 0.2 * W) if mesh else W)
        f = fit_model(prep, s, refine=False)
        if best is None or f.rss < best.rss:
            best = f
    names = [n for n, _, _ in best.spec.hyper()]
    rel = {i: (0.6 if n in ("backlash_width", "presliding_k") else 0.02) for i, n in enumerate(names)}
    free = [i for i, n in enumerate(names) if n in ("backlash_width", "presliding_k")]
    f2 = fit_model(prep, best.spec, rel_bounds=rel, free=free)
    if f2.rss > best.rss:
        f2 = best
    return {"seed": seed, "named": [a.kind for a in res.accepted], "trajectory": r.meta["trajectory"], "gap": b,
            "width_play": W, "width_compliant": f2.spec.backlash_width, "disp_compliant": 1.0 / f2.spec.presliding_k,
            "rss_ratio": f2.rss / res.final.rss, "err_play": W / b - 1, "err_compliant": f2.spec.backlash_width / b - 1,
            "quanta": q}


def _line(o):
    return (f"gap {o['gap']:.3g}: play {o['err_play']:+.0%}, compliant {o['err_compliant']:+.0%} "
            f"(disp {o['disp_compliant']:.3g} = {o['disp_compliant'] / o['quanta']:.1f} q), rss ratio {o['rss_ratio']:.3f}")


def main(argv, fn=one, line=_line):
    """Run ``fn`` on the seeds ``argv[2:]`` (2 workers), print ``line(o)`` for each record where
    backlash was named (the seed and named kinds otherwise), write the outputs to ``argv[1]``."""
    outs = []
    with ProcessPoolExecutor(2) as ex:
        for o in ex.map(fn, [int(x) for x in argv[2:]]):
            outs.append(o)
            if "gap" in o:
                print(o["seed"], o["trajectory"], o["named"], line(o), flush=True)
            else:
                print(o["seed"], o["named"], flush=True)
    json.dump(outs, open(argv[1], "w"), indent=1)

if __name__ == "__main__":
    main(sys.argv)
