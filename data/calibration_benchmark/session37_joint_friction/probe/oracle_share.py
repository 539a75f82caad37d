"""Session 37 probe: change2's two-mass gap with the TRUE load share (and optionally true zeta)."""
import sys, os, json, importlib, tempfile, pathlib, time
sys.path.insert(0, os.getcwd())
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "tools"))
from jobs import GEN, map_jobs


def one(job):
    gen, s, mode = job
    mod = importlib.import_module(GEN[gen])
    import plant.calibration.two_mass as tmm
    from plant.calibration.report import calibrate
    r = mod.make_record(s)
    tm = r.meta.get("two_mass", {})
    K = tm.get("stiffness_nm_rad")
    jm = tm.get("J_m", tm.get("motor_inertia_kg_m2")); jl = tm.get("J_l", tm.get("load_inertia_kg_m2"))
    if mode in ("share", "both"):
        tmm.NOMINAL_SHARE = jl / (jm + jl)
    if mode == "both":
        z = tm.get("damping_ratio")
        if z is None:
            c = tm.get("damping_nms_rad"); jr = jm * jl / (jm + jl); z = c / (2 * (K * jr) ** 0.5)
        tmm.NOMINAL_ZETA = z
    d = pathlib.Path(tempfile.mkdtemp()); r.write_csv(d / "r.csv")
    rep = calibrate(d / "r.csv", d / "out", plots=False, gear_stiffness=K)
    out = dict(gen=gen, seed=s, mode=mode, share=tmm.NOMINAL_SHARE, zeta=tmm.NOMINAL_ZETA,
               truth=r.truth["backlash"]["width_rad"], named=[e["kind"] for e in rep["effects"]])
    for e in rep["effects"]:
        if e["kind"] == "backlash":
            out.update(gap=e.get("gap_rad"), tm=e.get("two_mass"))
    if out.get("gap"):
        out["err"] = out["gap"] / out["truth"] - 1
        mg = (out.get("tm") or {}).get("massless_gap"); out["err_massless"] = mg / out["truth"] - 1 if mg else None
        out["gain"] = (out.get("tm") or {}).get("gain")
    print(json.dumps({k: v for k, v in out.items() if k != "tm"}), flush=True)
    return out


if __name__ == "__main__":
    jobs = []
    for a in sys.argv[2:]:
        g, s, m = a.split(":"); jobs.append((g, int(s), m))
    json.dump(map_jobs(one, jobs, workers=int(os.environ.get("WORKERS", "2"))), open(sys.argv[1], "w"), indent=1, default=str)
