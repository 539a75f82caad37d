"""Session 28: long records (10⁶ samples, as `benchmark-calibration --long` makes them) calibrated by
the code of a given tree. Usage: python long_runner.py TREE OUT.json SEED ...

Records are generated once into /tmp/s28_long/ (shared by both trees), each calibration runs in
its own child process (two at a time); the baseline's coefficients are read from report.json.
"""
import json, os, subprocess, sys, time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

N = 1_000_000
REC = Path("/tmp/s28_long")

CHILD = r'''
import json, sys, time, resource
sys.path.insert(0, sys.argv[1])
from plant.calibration.report import calibrate
import plant.calibration.fit as F
t0 = time.time()
rep = calibrate(sys.argv[2], sys.argv[3], plots=False)
print(json.dumps({"fit_module": F.__file__, "wall_s": time.time() - t0,
                  "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "named": [e["kind"] for e in rep["effects"]],
                  "effects": [{"kind": e["kind"], "params": e["params"]} for e in rep["effects"]],
                  "baseline": rep.get("baseline"), "unexplained": rep["unexplained"]}, default=str))
'''


def ensure_record(seed: int) -> tuple[Path, dict]:
    REC.mkdir(exist_ok=True)
    csv, meta = REC / f"long_{seed}.csv", REC / f"long_{seed}.json"
    if not csv.exists():
        sys.path.insert(0, "/work/main")
        from plant.calibration.bench_records import make_record
        r = make_record(seed, n_samples=N)
        r.write_csv(csv)
        meta.write_text(json.dumps({"hidden": list(r.hidden), "truth": r.truth, "meta": r.meta}, default=str))
    return csv, json.loads(meta.read_text())


def one(tree: str, seed: int) -> dict:
    csv, meta = ensure_record(seed)
    out = REC / f"run_{Path(tree).name}_{seed}"
    p = subprocess.run([sys.executable, "-c", CHILD, tree, str(csv), str(out)], capture_output=True, text=True,
                       env={**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"})
    if p.returncode:
        return {"seed": seed, "ok": False, "error": p.stderr[-2000:]}
    res = json.loads(p.stdout.strip().splitlines()[-1])
    return {"seed": seed, "ok": True, "hidden": meta["hidden"], "fc": meta["meta"]["fc"], "fv": meta["meta"]["fv"], **res}


def main() -> None:
    tree, out, seeds = sys.argv[1], sys.argv[2], [int(s) for s in sys.argv[3:]]
    for s in seeds:              # generate serially (shared files), then calibrate two at a time
        ensure_record(s)
    with ThreadPoolExecutor(2) as ex:
        rows = list(ex.map(lambda s: one(tree, s), seeds))
    for r in rows:
        print(r["seed"], r.get("hidden"), r.get("named"), f"{r.get('wall_s', 0):.0f}s", r.get("error", "")[-300:], flush=True)
    Path(out).write_text(json.dumps(rows, indent=1, default=str))


if __name__ == "__main__":
    main()
