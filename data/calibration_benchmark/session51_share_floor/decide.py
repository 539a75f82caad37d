"""Session 51's bars on the decision run: CHANGE.json (all records, floor_runner.py) against
MAIN.json (main on the change's flagged records and a random sample of the others). Main's result on
an unflagged record is the change's (the floor refused nothing there, so the loop ran as main's);
the sample checks that. Usage: python decide.py CHANGE.json MAIN.json"""
import json, sys
import importlib
sys.path.insert(0, ".")
ch = json.load(open(sys.argv[1])); mn = {(o["generator"], o["seed"]): o for o in json.load(open(sys.argv[2]))}
GEN = {"independent": "plant.calibration.bench_records", "blind": "plant.calibration.blind_records"}
ool = {g: set(importlib.import_module(m).OUT_OF_LIBRARY) for g, m in GEN.items()}
same = [k for k, o in mn.items() if not next(c for c in ch if (c["generator"], c["seed"]) == k)["flag"]]
bad = [k for k in same if set(mn[k]["named"]) != set(next(c for c in ch if (c["generator"], c["seed"]) == k)["named"])]
print(f"unflagged sample run by main: {len(same)}, named sets differing: {len(bad)} {bad}")
for g in ("independent", "blind"):
    rs = [c for c in ch if c["generator"] == g]
    m = {(c["generator"], c["seed"]): mn.get((c["generator"], c["seed"]), c) for c in rs}
    gained = [c["seed"] for c in rs if c["exact"] and not m[(g, c["seed"])]["exact"]]
    lost = [c["seed"] for c in rs if not c["exact"] and m[(g, c["seed"])]["exact"]]
    clean = lambda o: not o["hidden"] and bool(o["named"])
    oolk = lambda o: bool(o["hidden"]) and set(o["hidden"]) <= ool[g] and bool(o["named"])
    print(f"{g}: records {len(rs)}, flagged {sum(c['flag'] for c in rs)}; exact main {sum(o['exact'] for o in m.values())} "
          f"change {sum(c['exact'] for c in rs)}; gained {len(gained)} {gained}; lost {len(lost)} {lost}; "
          f"clean invented main {sum(map(clean, m.values()))} change {sum(map(clean, rs))} (of {sum(not c['hidden'] for c in rs)}); "
          f"out-of-library with a library kind main {sum(map(oolk, m.values()))} change {sum(map(oolk, rs))} "
          f"(of {sum(bool(c['hidden']) and set(c['hidden']) <= ool[g] for c in rs)})")
    for c in rs:
        k = (g, c["seed"])
        if c["flag"] and set(c["named"]) != set(m[k]["named"]):
            print(f"   {c['seed']} hidden {c['hidden']} main {m[k]['named']} change {c['named']}")
