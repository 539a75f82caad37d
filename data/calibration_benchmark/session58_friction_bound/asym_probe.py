import sys, os, json
sys.path.insert(0, os.getcwd()); sys.path.insert(0, "data/calibration_benchmark/session25_sweep_guard")
from concurrent.futures import ProcessPoolExecutor
import runner
def one(job):
    gen, arg = job
    try:
        mod, r, rep, wall = runner.calibrate_record(gen, arg)
    except Exception as e:
        return {"gen": gen, "arg": arg, "err": str(e)}
    a = [e["params"] for e in rep["effects"] if e["kind"] == "asymmetric_friction"]
    rj = [c for c in rep["rejected"] if c["kind"] == "asymmetric_friction"]
    return {"gen": gen, "arg": arg, "hidden": list(r.hidden), "named": [e["kind"] for e in rep["effects"]],
            "asym": a[0] if a else None, "base": rep["baseline"]["params"], "truth": r.truth.get("asymmetric_friction"),
            "traj": r.meta.get("trajectory"), "two_mass": bool(r.meta.get("two_mass")),
            "rej": [c["reason"][:200] for c in rj]}
if __name__ == "__main__":
    jobs = [tuple(a.split("/")) for a in sys.argv[2:]]
    out = []
    with ProcessPoolExecutor(2) as ex:
        for o in ex.map(one, jobs):
            out.append(o); print(json.dumps(o, default=str)[:400], flush=True)
    json.dump(out, open(sys.argv[1], "w"), indent=0, default=str)
