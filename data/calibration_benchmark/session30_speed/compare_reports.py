"""Pair the runner's report dirs of two runs by seed and compare every number in them (session 30).

Usage: python compare_reports.py GENERATOR CUT_EPOCH_S. The runner (session25_sweep_guard/runner.py)
leaves each record's report in /tmp/s24_GENERATOR_SEED_*/out/; directories older than CUT_EPOCH_S belong
to the first run, newer ones to the second. Prints each seed whose reports differ and the worst
relative difference over all numbers (paths excluded).
"""
import glob, json, os, sys, math
gen = sys.argv[1]
pairs = {}
for d in glob.glob(f"/tmp/s24_{gen}_*"):
    seed = int(d.split("_")[2])
    pairs.setdefault(seed, []).append(d)
def nums(o, path=""):
    if isinstance(o, dict):
        for k, v in o.items():
            if k in ("model_file", "record"): continue
            yield from nums(v, f"{path}.{k}")
    elif isinstance(o, list):
        for i, v in enumerate(o): yield from nums(v, f"{path}[{i}]")
    else:
        yield path, o
worst_all = 0; n_ident = 0; n = 0
cut = float(sys.argv[2])  # epoch seconds separating the runs
for seed in sorted(pairs):
    ds = [d for d in pairs[seed] if os.path.exists(d + "/out/report.json")]
    a = [d for d in ds if os.path.getmtime(d) < cut]; b = [d for d in ds if os.path.getmtime(d) >= cut]
    if not a or not b: continue
    A = json.load(open(max(a, key=os.path.getmtime) + "/out/report.json")); B = json.load(open(max(b, key=os.path.getmtime) + "/out/report.json"))
    na, nb = dict(nums(A)), dict(nums(B))
    n += 1
    if na.keys() != nb.keys():
        print(seed, "STRUCTURE DIFFERS", sorted(set(na) ^ set(nb))[:6]); continue
    worst = 0; where = None
    for k in na:
        x, y = na[k], nb[k]
        if isinstance(x, (int, float)) and isinstance(y, (int, float)) and not isinstance(x, bool):
            if x == y or (isinstance(x, float) and math.isnan(x) and math.isnan(y)): continue
            r = abs(x - y) / max(abs(x), abs(y), 1e-300)
            if r > worst: worst, where = r, k
        elif x != y:
            worst, where = float("inf"), k
    n_ident += worst == 0
    worst_all = max(worst_all, worst)
    if worst: print(seed, f"max rel diff {worst:.3g} at {where}")
print(f"{n} pairs, {n_ident} identical in every number, worst relative difference {worst_all:.3g}")
