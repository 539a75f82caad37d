"""Session 36 decision runs: calibrate every never-used record with hidden backlash (stiffness declared)
and keep both gaps (massless, two-mass). Run from the change's tree.
Usage: python run_decision.py OUT.json GEN:LO-HI ..."""
import sys, os, json, importlib, tempfile, pathlib, time
sys.path.insert(0, os.getcwd())
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "tools"))
from jobs import GEN, map_jobs, seed_jobs  # noqa: E402


def one(job):
    gen, s = job
    mod = importlib.import_module(GEN[gen])
    hidden = mod.plan()[s % len(mod.plan())]
    if "backlash" not in hidden:
        return None
    from plant.calibration.report import calibrate
    r = mod.make_record(s)
    K = r.meta.get("two_mass", {}).get("stiffness_nm_rad")
    d = pathlib.Path(tempfile.mkdtemp())
    r.write_csv(d / "r.csv")
    t0 = time.time()
    rep = calibrate(d / "r.csv", d / "out", plots=False, gear_stiffness=K)
    out = {"gen": gen, "seed": s, "hidden": list(hidden), "named": [e["kind"] for e in rep["effects"]],
           "truth_width_rad": r.truth["backlash"]["width_rad"], "wall_s": time.time() - t0}
    for e in rep["effects"]:
        if e["kind"] == "backlash":
            out.update(gap_rad=e.get("gap_rad"), gap_method=e.get("gap_method"), two_mass=e.get("two_mass"))
    return out


if __name__ == "__main__":
    out = map_jobs(one, seed_jobs(sys.argv[2:]))
    json.dump(out, open(sys.argv[1], "w"), indent=1)
    print(len(out), "records")
