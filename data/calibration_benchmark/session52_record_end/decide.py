"""Session 52's bars 1 and 2 on the decision run: CHANGE.json and MAIN.json, both every record of
never-used 21940–22059 (`tools/flag_runner.py` outputs; the change acts on every record, so both ran all).
Usage (repository root): python decide.py CHANGE.json MAIN.json"""
import importlib, json, sys
sys.path.insert(0, ".")
GEN = {"independent": "plant.calibration.bench_records", "blind": "plant.calibration.blind_records"}
ch = {(o["generator"], o["seed"]): o for o in json.load(open(sys.argv[1]))}
mn = {(o["generator"], o["seed"]): o for o in json.load(open(sys.argv[2]))}
assert ch.keys() == mn.keys(), (len(ch), len(mn))
tot_g = tot_l = 0
for g in GEN:
    ool = set(importlib.import_module(GEN[g]).OUT_OF_LIBRARY)
    keys = sorted(k for k in ch if k[0] == g)
    c, m = [ch[k] for k in keys], [mn[k] for k in keys]
    gained = [k[1] for k in keys if ch[k]["exact"] and not mn[k]["exact"]]
    lost = [k[1] for k in keys if not ch[k]["exact"] and mn[k]["exact"]]
    tot_g += len(gained); tot_l += len(lost)
    clean = lambda o: not o["hidden"] and bool(o["named"])
    oolk = lambda o: bool(o["hidden"]) and set(o["hidden"]) <= ool and bool(o["named"])
    print(f"{g}: records {len(keys)}; exact main {sum(o['exact'] for o in m)} change {sum(o['exact'] for o in c)}; "
          f"gained {len(gained)} {gained}; lost {len(lost)} {lost}; clean invented main {sum(map(clean, m))} "
          f"change {sum(map(clean, c))} (of {sum(not o['hidden'] for o in c)}); out-of-library with a library kind "
          f"main {sum(map(oolk, m))} change {sum(map(oolk, c))} (of {sum(bool(o['hidden']) and set(o['hidden']) <= ool for o in c)})")
    for k in keys:
        if set(ch[k]["named"]) != set(mn[k]["named"]):
            print(f"   {k[1]} hidden {ch[k]['hidden']} main {mn[k]['named']} change {ch[k]['named']}")
    wm, wc = sum(o["wall_s"] for o in m), sum(o["wall_s"] for o in c)
    print(f"   calibration wall: main {wm:.0f} s, change {wc:.0f} s ({wc / wm:.2f}×; both runs shared the machine)")
print(f"pooled: gained {tot_g}, lost {tot_l}")
