"""Session 16 probe: the gap from session 15's compliant mesh with the given stiffness.

Session 15's mesh (``session15_reversal_events/compliant_mesh_probe.py``: a play of width
``b + 2d``, the transmitted torque ramping over ``d`` outside the gap ``b``) had ``d`` free and
lost large gaps. Here ``d = Ts/K``: the travel over which the gear spring of the given stiffness
``K`` (the record's ``two_mass`` stiffness, as the benchmark passes it to ``--gear-stiffness``)
winds up to the fit's static level ``Ts`` (``loop.friction_levels``; two fixed-point passes), and
only ``b`` is refined. Compared with main's ``loop.backlash_gap`` on the same loop result.

Usage: python mesh_gap_probe.py OUT.json SEED...   (backlash-only records)
"""
import os, pathlib, sys, tempfile

import numpy as np

sys.path.insert(0, os.getcwd())
HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "session15_reversal_events"))
import compliant_mesh_probe as mesh  # noqa: E402  (its design_full: the package's plus the mesh case)
import plant.calibration.fit as _fit  # noqa: E402


def one(seed):
    _fit.design_full = mesh.design_full
    from plant.calibration.bench_records import make_record
    from plant.calibration.fit import fit_model, prepare
    from plant.calibration.io import load_record
    from plant.calibration.loop import backlash_gap, friction_levels, run_loop
    r = make_record(seed, ("backlash",))
    d = pathlib.Path(tempfile.mkdtemp()); r.write_csv(d / "r.csv")
    prep = prepare(load_record(d / "r.csv"))
    res = run_loop(prep)
    named = [a.kind for a in res.accepted]
    if "backlash" not in named or res.final.spec.presliding_k is not None:
        return {"seed": seed, "named": named}
    gap = r.truth["backlash"]["width_rad"]
    K = r.meta["two_mass"]["stiffness_nm_rad"]
    W = res.final.spec.backlash_width
    fc, ts = friction_levels(res.final)
    gap_formula = backlash_gap(W, fc, ts, K)
    fit = res.final
    b = max(gap_formula, 0.05 * W)
    for _ in range(2):                      # fixed point: d from the current fit's static level
        _, ts_cur = friction_levels(fit)
        dd = max(ts_cur / K, 1e-3 * prep.position_resolution)
        best = None
        for bb in np.geomspace(0.02 * W, 1.5 * W, 25):
            s = fit.spec.copy() if fit is not res.final else res.final.spec.copy()
            s.backlash_width, s.presliding_k = float(bb), 1.0 / dd
            f = fit_model(prep, s, refine=False)
            if best is None or f.rss < best.rss:
                best = f
        names = [n for n, _, _ in best.spec.hyper()]
        free = [i for i, n in enumerate(names) if n == "backlash_width"]
        rel = {i: 0.3 for i in free}
        f2 = fit_model(prep, best.spec, rel_bounds=rel, free=free)
        fit = f2 if f2.rss <= best.rss else best
        b = fit.spec.backlash_width
    return {"seed": seed, "named": named, "trajectory": r.meta["trajectory"], "gap": gap, "K": K, "width": W,
            "gap_formula": gap_formula, "gap_mesh": b, "err_formula": gap_formula / gap - 1, "err_mesh": b / gap - 1,
            "err_width": W / gap - 1, "windup_over_gap": (fc + ts) / (2 * K) / gap, "rss_ratio": fit.rss / res.final.rss}


def _line(o):
    return (f"gap {o['gap']:.3g}: width {o['err_width']:+.0%}, formula {o['err_formula']:+.0%}, mesh {o['err_mesh']:+.0%} "
            f"(half wind-up/gap {o['windup_over_gap']:.2f}; rss ratio {o['rss_ratio']:.3f})")


if __name__ == "__main__":
    import compliant_play_probe as play
    play.main(sys.argv, one, _line)
