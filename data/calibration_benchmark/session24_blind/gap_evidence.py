"""Session 24 probe: for records where the gap-inside-the-spring candidate is named, the gap, the
wind-up 2Fc/K and the end of its evidence (its gain over the declared spring alone and that
comparison's z). Run from a tree with gap_in_spring_not_kept.diff applied (gap_evidence.txt was).
Usage: python gap_evidence.py OUT.json GENERATOR SEED[:hidden] ..."""
import json, os, sys
from concurrent.futures import ProcessPoolExecutor
sys.path.insert(0, os.getcwd())
from runner import calibrate_record   # this folder's runner (same generation and calibration)


def one(job):
    gen, arg = job
    import re
    _, r, rep, _ = calibrate_record(gen, arg)
    out = {"arg": arg, "hidden": list(r.hidden), "named": [e["kind"] for e in rep["effects"]],
           "truth_gap": r.truth.get("backlash", {}).get("width_rad")}
    for e in rep["effects"]:
        if e["kind"] == "backlash":
            out["gap"] = e["params"]["width_rad"]
            m = re.search(r"wind-up 2Fc/K = ([0-9.eE+-]+)", e["evidence"])
            out["windup"] = float(m.group(1)) if m else None
            out["evidence"] = e["evidence"][-400:]
    out["log_steps"] = [l[:300] for l in rep["log"] if "backlash" in l][:3]
    return out


if __name__ == "__main__":
    gen = sys.argv[2]
    with ProcessPoolExecutor(2) as ex:
        res = list(ex.map(one, [(gen, a) for a in sys.argv[3:]]))
    for o in res:
        print(json.dumps({k: o.get(k) for k in ("arg", "hidden", "named", "truth_gap", "gap", "windup")}))
        print("   ", o.get("evidence"))
    json.dump(res, open(sys.argv[1], "w"), indent=1)
