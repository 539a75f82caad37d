import sys, os, dataclasses, math, tempfile, pathlib
sys.path.insert(0, os.getcwd())
import numpy as np
from plant.calibration import fit, loop
from plant.calibration.io import load_record
from plant.calibration.bench_records import make_record
from plant.calibration.blind_records import make_record as mb
gen, seed = sys.argv[1], int(sys.argv[2])
r = (make_record if gen == "i" else mb)(seed)
d = pathlib.Path(tempfile.mkdtemp()); r.write_csv(d / "r.csv")
K = r.meta["two_mass"]["stiffness_nm_rad"]; gap = r.truth["backlash"]["width_rad"]
prep = fit.prepare(load_record(d / "r.csv"))
cfg = loop.LoopConfig(gear_stiffness=K)
base = fit.fit_model(prep, fit.ModelSpec())
print("meta fc", r.meta.get("fc"), "K", K, "gap", gap, "2fc/K", 2 * r.meta["fc"] / K, "res", prep.position_resolution)
print("baseline", base.rss, base.params())
fc = loop._spring_coulomb(prep, base, cfg)
print("spring fc", fc, "qs", loop._quasi_static_spring(prep, base, cfg))
for name, spec in [("spring", dataclasses.replace(fit.ModelSpec(), gear_stiffness=K, spring_coulomb=fc or r.meta["fc"])),
                   ("spring+gap", dataclasses.replace(fit.ModelSpec(), gear_stiffness=K, spring_coulomb=fc or r.meta["fc"], backlash_width=gap)),
                   ("spring true fc", dataclasses.replace(fit.ModelSpec(), gear_stiffness=K, spring_coulomb=r.meta["fc"])),
                   ("spring+gap true fc", dataclasses.replace(fit.ModelSpec(), gear_stiffness=K, spring_coulomb=r.meta["fc"], backlash_width=gap)),
                   ("deadzone true", dataclasses.replace(fit.ModelSpec(), backlash_width=gap)),
                   ("deadzone gap+windup", dataclasses.replace(fit.ModelSpec(), backlash_width=gap + 2 * r.meta["fc"] / K))]:
    try:
        f = fit.fit_model(prep, spec, refine=False)
        print(f"{name:22s} rss {f.rss:.5g} ({100*(base.rss-f.rss)/base.rss:+.1f} %)", {k: round(v, 4) for k, v in f.params().items()})
    except Exception as e:
        print(name, "ERR", e)
from plant.calibration import residuals as res
print("decimated dt", prep.dt_s, "dec size", prep.y_dec.size)
for name, spec in [("baseline", fit.ModelSpec()),
                   ("spring true fc", dataclasses.replace(fit.ModelSpec(), gear_stiffness=K, spring_coulomb=r.meta["fc"])),
                   ("deadzone true", dataclasses.replace(fit.ModelSpec(), backlash_width=gap))]:
    f = fit.fit_model(prep, spec, refine=False)
    rv = res.reversal_profile(prep.t_dec, prep.dq_dec, f.residual, 0.1)
    m = rv["mean"]; lag = rv["lag_s"]
    sel = slice(0, None, max(1, len(m)//25))
    print(f"{name:16s} n_rev {rv['n_reversals']} share {rv['share_pct']:.0f}% | " + " ".join(f"{x:+.2f}" for x in m[sel]))
print("lags", " ".join(f"{x:+.3f}" for x in lag[sel]))
fb = fit.fit_model(prep, fit.ModelSpec(), refine=False)
fs_ = fit.fit_model(prep, dataclasses.replace(fit.ModelSpec(), gear_stiffness=K, spring_coulomb=r.meta["fc"]), refine=False)
d = fs_.residual**2 - fb.residual**2
t = prep.t_dec; n = 20
edges = np.linspace(t[0], t[-1], n + 1)
for a, b in zip(edges[:-1], edges[1:]):
    m = (t >= a) & (t < b)
    print(f"{a:7.1f}-{b:7.1f}s  d {d[m].sum():+8.3f}  base {np.sum(fb.residual[m]**2):8.3f}  |v| mean {np.mean(np.abs(prep.dq_dec[m])):.4f} min {np.min(np.abs(prep.dq_dec[m])):.2e}")
print("N dec", t.size, "mask?", getattr(prep, "mask", None) is not None)
print("first samples")
for i in list(range(0, 40, 2)) + list(range(40, 400, 40)):
    print(f"t {t[i]:.3f} v {prep.dq_dec[i]:+.4f} rb {fb.residual[i]:+.3f} rs {fs_.residual[i]:+.3f}")
print("prep.t[0]", prep.t[0], "q0", prep.q[0], "dq0", prep.dq[0])
