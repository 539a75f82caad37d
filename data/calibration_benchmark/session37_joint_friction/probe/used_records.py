"""Session 37 probes on the used backlash records (fixed backlash seeds and session 36's decision records):
the two-mass gap per record at given (load share, damping ratio) points, with the fit's friction.

Modes (each wrote one of this folder's outputs):
  spread      shares 0.3/0.5/0.7 at zeta 0.1 and zeta 0.03/0.3 at share 0.5, session 36's second attempt
              (the gap alone, JOINT_FRICTION off) -> share_spread_out.json: does the spread tell right from wrong?
  fit-params  share 0.5, zeta 0.1, JOINT_FRICTION off, with the fit's friction per record -> fit_params_out.json
  joint       share 0.5, zeta 0.1, the landed code (the load's friction levels refitted) ->
              joint_on_used_records.json
Run from the repository root: python .../probe/used_records.py MODE OUT.json [GEN:SEED ...]
(without GEN:SEED arguments: all 94 used records). Every mode records the fit's friction and the
friction scales (the three scripts these replace differed only in their grid and in those fields)."""
import sys, os, json, importlib, tempfile, pathlib, time
sys.path.insert(0, os.getcwd())
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "tools"))
from jobs import GEN, map_jobs  # noqa: E402

GRIDS = {"spread": [(0.3, 0.1), (0.5, 0.1), (0.7, 0.1), (0.5, 0.03), (0.5, 0.3)],
         "fit-params": [(0.5, 0.1)], "joint": [(0.5, 0.1)]}
SESSION36 = pathlib.Path(__file__).resolve().parents[2] / "session36_two_mass"


def one(job):
    mode, gen, s = job
    mod = importlib.import_module(GEN[gen])
    import plant.calibration.two_mass as tmm
    import plant.calibration.report as rp
    tmm.JOINT_FRICTION = mode == "joint"
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
        for sh, z in GRIDS[mode]:
            tmm.NOMINAL_SHARE, tmm.NOMINAL_ZETA = sh, z
            g, info = tmm.two_mass_gap(prep, fit, K, gap0, k)
            res.append(dict(share=sh, zeta=z, gap=info.get("gap"), used=g is not None, gain=info.get("cv_gain_pct"),
                            rss=info.get("rss"), rss_massless=info.get("rss_massless"),
                            cs=info.get("coulomb_scale"), vs=info.get("viscous_scale")))
        out["grid"] = res
    out["wall_s"] = time.time() - t0
    print(json.dumps(out, default=str), flush=True)
    return out


def used_records():
    jobs = [("independent", s) for s in (4, 10, 22, 28, 33, 35)]
    for f in ("decision_10060_10659.json", "decision2_10660_11259.json"):
        for x in json.load(open(SESSION36 / f)):
            if x and x.get("gap_rad"):
                jobs.append((x["gen"], x["seed"]))
    return jobs


if __name__ == "__main__":
    mode, path = sys.argv[1], sys.argv[2]
    if mode not in GRIDS:
        sys.exit(f"used_records.py: mode {mode!r}: expected one of {sorted(GRIDS)}")
    picked = [(a.split(":")[0], int(a.split(":")[1])) for a in sys.argv[3:]] or used_records()
    json.dump(map_jobs(one, [(mode, g, s) for g, s in picked]), open(path, "w"), indent=1, default=str)
