import sys, os, json, tempfile, importlib
sys.path.insert(0, os.getcwd())
from plant.calibration.report import calibrate
GEN = {"independent": "plant.calibration.bench_records", "blind": "plant.calibration.blind_records"}
gen, seed = sys.argv[1], int(sys.argv[2])
rec = importlib.import_module(GEN[gen]).make_record(seed)
d = tempfile.mkdtemp(); rec.write_csv(d + "/r.csv")
print(rec.hidden, getattr(rec, "truth", None) or getattr(rec, "params", None))
rep = calibrate(d + "/r.csv", d + "/out", plots=False)
for l in rep["log"]: print("LOG", l[:400])
for r in rep["rejected"]:
    if r["kind"] in sys.argv[3:]: print("REJ", r["step"], r["kind"], r["reason"][:300], r.get("also"))
print("named", [e["kind"] for e in rep["effects"]], "unexpl", [(u["domain"], u.get("kind"), round(u["share_pct"],1)) for u in rep["unexplained"]])
