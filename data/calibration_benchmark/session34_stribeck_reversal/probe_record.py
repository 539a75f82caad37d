import sys, os, json
sys.path.insert(0, os.getcwd())
sys.path.insert(0, "/work/main/data/calibration_benchmark/session25_sweep_guard")
from runner import calibrate_record
mod, r, rep, wall = calibrate_record(sys.argv[1], sys.argv[2])
print("hidden", r.hidden, json.dumps(r.truth, default=str)[:400])
print("named", [(e["kind"], e.get("params")) for e in rep["effects"]])
print("\n".join(l[:400] for l in rep["log"]))
for x in rep["rejected"]:
    if x["kind"] in ("presliding", "backlash"): print("REJ", x["kind"], x["step"], str(x["reason"])[:300])
for e in rep["effects"]: print("EV", e["kind"], str(e.get("evidence"))[:600])
