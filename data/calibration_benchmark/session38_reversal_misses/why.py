"""Session 38: why a hidden reversal kind (pre-sliding, backlash) is not named — on the records of a
runner output where it was missed (used records). For the hidden reversal kind(s): the record's
reversal count, the candidate's best gain and z over the steps, and the reason of its last refusal.
Usage (from the repository root): python why.py RUNS.json OUT.json"""
import json, pathlib, sys
sys.path.insert(0, ".")
here = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(here.parent / "session25_sweep_guard"))
sys.path.insert(0, str(here.parent / "tools"))
from jobs import map_jobs
from runner import calibrate_record

REV = {"presliding", "backlash"}


def one(job):
    gen, seed = job
    _, r, rep, _ = calibrate_record(gen, str(seed))
    out = {"generator": gen, "seed": seed, "hidden": list(r.hidden), "named": [e["kind"] for e in rep["effects"]],
           "trajectory": r.meta.get("trajectory") or (r.meta.get("trajectory_info") or {}).get("kind"), "kinds": {}}
    log = "\n".join(rep.get("log", []))
    out["n_reversals"] = next((u["n_reversals"] for u in rep.get("undecided", []) if "n_reversals" in u), None)
    for k in sorted(set(r.hidden) & REV):
        rej = [x for x in rep["rejected"] if x["kind"] == k]
        best = max(rej, key=lambda x: x["cv_gain_pct"] if x["cv_gain_pct"] is not None else -1e9) if rej else None
        und = [u for u in rep.get("undecided", []) if u["kind"] == k]
        out["kinds"][k] = {"best": best, "last_reason": rej[-1]["reason"] if rej else None,
                           "undecided": und[0]["reason"] if und else None, "tried": f" {k} " in log}
    return out


if __name__ == "__main__":
    runs = json.load(open(sys.argv[1]))
    jobs = [(o["generator"], o["seed"]) for o in runs
            if not o["exact"] and (set(o["hidden"]) & REV) - set(o["named"])]
    res = map_jobs(one, jobs, chunksize=2)
    json.dump(res, open(sys.argv[2], "w"), indent=1)
    for o in res:
        for k, v in o["kinds"].items():
            b = v["best"]
            g = f"{b['cv_gain_pct']:.1f} % z {b['cv_z']:.1f}" if b and b["cv_gain_pct"] is not None else "-"
            print(o["generator"], o["seed"], o["trajectory"], k, "named:", o["named"], "| best", g, "| und", v["undecided"],
                  "| nrev", o["n_reversals"], "|", (v["last_reason"] or "not tried")[:150], flush=True)
