"""Session 37 probe (used records only): change2's two-mass gap at load shares 0.3/0.5/0.7 (zeta 0.1)
and, at share 0.5, zeta 0.03/0.3 — does the gap's spread over nuisance values tell right from wrong?"""
import sys, os, json, importlib, tempfile, pathlib, time
sys.path.insert(0, os.getcwd())
sys.path.insert(0, "/work/main/data/calibration_benchmark/tools")
from jobs import GEN, map_jobs

GRID = [(0.5, 0.1)]


def one(job):
    gen, s = job
    mod = importlib.import_module(GEN[gen])
    import plant.calibration.two_mass as tmm
    import plant.calibration.report as rp
    cap = {}
    orig = rp.two_mass_gap

    def wrap(prep, fit, K, gap0, k):
        cap["args"] = (prep, fit, K, gap0, k)
        return orig(prep, fit, K, gap0, k)
    rp.two_mass_gap = wrap
    r = mod.make_record(s)
    tm = r.meta.get("two_mass", {})
    K = tm.get("stiffness_nm_rad")
    jm = tm.get("J_m", tm.get("motor_inertia_kg_m2")); jl = tm.get("J_l", tm.get("load_inertia_kg_m2"))
    d = pathlib.Path(tempfile.mkdtemp()); r.write_csv(d / "r.csv")
    t0 = time.time()
    rep = rp.calibrate(d / "r.csv", d / "out", plots=False, gear_stiffness=K)
    truth = r.truth["backlash"]["width_rad"]
    out = dict(gen=gen, seed=s, truth=truth, true_share=jl / (jm + jl), named=[e["kind"] for e in rep["effects"]])
    for e in rep["effects"]:
        if e["kind"] == "backlash":
            out["massless_gap"] = (e.get("two_mass") or {}).get("massless_gap", e.get("gap_rad"))
    if "args" in cap:
        prep, fit, K, gap0, k = cap["args"]
        out["params"] = {kk: float(v) for kk, v in fit.params().items()}
        out["stribeck_vs"] = fit.spec.stribeck_vs
        out["K"] = K
        out["gap0"] = gap0
        out["lf"] = vars(tmm.LoadFriction.of(fit))
        res = []
        for sh, z in GRID:
            tmm.NOMINAL_SHARE, tmm.NOMINAL_ZETA = sh, z
            g, info = tmm.two_mass_gap(prep, fit, K, gap0, k)
            res.append(dict(share=sh, zeta=z, gap=info.get("gap"), used=g is not None, gain=info.get("cv_gain_pct"),
                            rss=info.get("rss"), rss_massless=info.get("rss_massless"), cs=info.get("coulomb_scale"), vs=info.get("viscous_scale")))
        out["grid"] = res
    out["wall_s"] = time.time() - t0
    print(json.dumps(out, default=str), flush=True)
    return out


if __name__ == "__main__":
    jobs = []
    for f in ("decision_10060_10659.json", "decision2_10660_11259.json"):
        for x in json.load(open("/work/main/data/calibration_benchmark/session36_two_mass/" + f)):
            if x and x.get("gap_rad"):
                jobs.append((x["gen"], x["seed"]))
    jobs = [("independent", s) for s in (4, 10, 22, 28, 33, 35)] + jobs
    json.dump(map_jobs(one, jobs), open(sys.argv[1], "w"), indent=1, default=str)
