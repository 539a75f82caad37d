"""Session 60 probe: at each step where no candidate passes, the two best library candidates (by held-out gain,
positive) fitted together: the pair against the current model, and each member against the pair without it.

Usage (repository root): python .../pair_probe.py OUT.json GEN:LO-HI ... The figures for used 27032 and 27092 in
docs/calibration.md ("Session 60, second part") are its output on those two records; its run over all of used
27010-27159 was stopped unread once the change itself was written, and the change's run there
(`change_used_27010_27159.*`) took its place. (Review, after the stop: a dead print branch removed.)"""
import sys, os, json
sys.path.insert(0, os.getcwd()); sys.path.insert(0, "data/calibration_benchmark/session25_sweep_guard")
sys.path.insert(0, "data/calibration_benchmark/tools")
import runner
from plant.calibration import loop

OUT = []
orig = loop._candidates


def merge(cur, a, b):
    s = cur.spec.copy()
    for c in (a, b):
        cs = c["fit"].spec
        s.gravity = s.gravity or cs.gravity
        s.position_periods = list(s.position_periods) + [p for p in cs.position_periods if p not in cur.spec.position_periods]
        s.time_frequencies = list(s.time_frequencies) + [f for f in cs.time_frequencies if f not in cur.spec.time_frequencies]
        for fld in ("asymmetric", "presliding_k", "backlash_width"):
            if getattr(cs, fld) != getattr(cur.spec, fld):
                setattr(s, fld, getattr(cs, fld))
    return s


def wrap(ctx):
    cands = orig(ctx)
    try:
        lib = [c for c in cands if c.get("kind") in loop.EFFECT_KINDS and c.get("fit") is not None]
        k = ctx.cfg.k_folds
        l0 = loop.cv_losses(ctx.prep, ctx.cur.spec, k)
        scored = []
        for c in lib:
            g, z = loop.cv_compare(l0, loop.cv_losses(ctx.prep, c["fit"].spec, k))
            scored.append((g, z, c))
        scored.sort(key=lambda t: -t[0])
        top = [t for t in scored if t[0] > 0][:2]
        if len(top) == 2:
            a, b = top[0][2], top[1][2]
            sp = merge(ctx.cur, a, b)
            lp = loop.cv_losses(ctx.prep, sp, k)
            gp, zp = loop.cv_compare(l0, lp)
            ga, za = loop.cv_compare(loop.cv_losses(ctx.prep, b["fit"].spec, k), lp)  # a beside b
            gb, zb = loop.cv_compare(loop.cv_losses(ctx.prep, a["fit"].spec, k), lp)  # b beside a
            OUT.append(dict(step=len(ctx.present), present=sorted(ctx.present), a=a["kind"], ga=top[0][0], za=top[0][1], b=b["kind"], gb0=top[1][0], zb0=top[1][1],
                            pair=(gp, zp), a_beside_b=(ga, za), b_beside_a=(gb, zb), a_line=str(a.get("line")), b_line=str(b.get("line"))))
    except Exception as e:
        OUT.append(f"error {e!r}")
    return cands


loop._candidates = wrap
from jobs import map_jobs, seed_jobs


def one(job):
    gen, seed = job
    OUT.clear()
    mod, r, rep, wall = runner.calibrate_record(gen, str(seed))
    last_step = len(rep["effects"]) + 1
    rej = [{k: x.get(k) for k in ("kind", "step", "cv_gain_pct", "cv_z", "rules")} | {"reason": x["reason"][:90]}
           for x in rep["rejected"]]
    return {"generator": gen, "seed": seed, "hidden": list(r.hidden), "named": [e["kind"] for e in rep["effects"]],
            "lib": list(mod.LIBRARY_KINDS), "steps": list(OUT), "rejected": rej, "log_tail": rep["log"][-3:]}


if __name__ == "__main__":
    res = map_jobs(one, seed_jobs(sys.argv[2:]), chunksize=2)
    json.dump(res, open(sys.argv[1], "w"), indent=1, default=str)
    print("done", len(res))
