import sys, os, json, tempfile, pathlib, dataclasses, math
sys.path.insert(0, os.getcwd())
import numpy as np
from plant.calibration import bench_records as BR
from plant.calibration.report import load_record, prepare
from plant.calibration.fit import fit_model, ModelSpec
from plant.calibration import loop as L
def go(seed, gen=BR):
    r = gen.make_record(int(seed))
    d = pathlib.Path(tempfile.mkdtemp()); r.write_csv(d / "rec.csv")
    prep = prepare(load_record(str(d / "rec.csv")))
    cfg = L.LoopConfig()
    base, st = L.fit_baseline(prep, cfg)
    cur = base
    v95 = float(np.percentile(np.abs(prep.dq_dec), 95))
    grid = v95 * np.logspace(math.log10(0.003), math.log10(0.3), 12)
    def with_s(spec):
        best=None
        for vs in grid:
            f = fit_model(prep, dataclasses.replace(spec.copy(), stribeck_vs=float(vs)), refine=False)
            if best is None or f.rss < best.rss: best = f
        return fit_model(prep, best.spec, rel_bounds=0.5)
    l0 = L.cv_losses(prep, cur.spec, 8)
    curS = with_s(cur.spec); lS = L.cv_losses(prep, curS.spec, 8)
    print(seed, r.hidden, "stribeck in base", st["included"], "S over cur", L.cv_compare(l0, lS), "vs", curS.spec.stribeck_vs)
    for kind, sp in (("presliding", None), ("backlash", None)):
        mov = L.res.moving_mask(prep.dq_dec)
        span = float(np.ptp(prep.q_dec[mov])) if mov.any() else float(np.ptp(prep.q_dec))
        vmax = float(np.percentile(np.abs(prep.dq), 99))
        ctx = L._Ctx(prep, cur, set(), cfg, False, span, vmax, True)
        cs = L._b_presliding(ctx) if kind == "presliding" else L._b_backlash(ctx)
        for c in cs:
            lc = L.cv_losses(prep, c["fit"].spec, 8)
            candS = fit_model(prep, dataclasses.replace(c["fit"].spec.copy(), stribeck_vs=curS.spec.stribeck_vs))
            lcS = L.cv_losses(prep, candS.spec, 8)
            print("  ", kind, "vs cur", np.round(L.cv_compare(l0, lc), 2), "vs cur+S (competition)", np.round(L.cv_compare(lS, lc), 2),
                  "cand+S vs cur+S (nuisance)", np.round(L.cv_compare(lS, lcS), 2), flush=True)
for s in sys.argv[1:]:
    go(s)
