import json, glob, sys
from scipy import stats
zc = 3.59
rows = []
for f in sorted(glob.glob(sys.argv[1] + "/u_*.json")):
    d = json.load(open(f))
    hid = set(d["hidden"]) & {"presliding", "backlash"}
    best = {}
    for c in d["cap"]:
        u = c["units"]
        if u is None or c["gain"] <= 0: continue
        if c["n_rev"] >= 13: continue
        key = c["kind"]
        if key not in best or u["z_equiv"] > best[key]["units"]["z_equiv"]:
            best[key] = c
    for k, c in best.items():
        u = c["units"]
        rows.append((d["gen"][:5], d["seed"], "HID" if k in hid else ("hid-other" if hid else "none"), k, c["n_rev"], u["k"], round(c["gain"], 1), round(c["z"], 2), round(u["t"], 1), round(u["z_equiv"], 2), round(u["share_units_pct"],1), min(u["g"])))
rows.sort(key=lambda r: -r[9])
for r in rows: print(*r)
