import json, math, sys
from scipy import stats
def zbest(m, B):
    W = sum(range(B - m + 1, B + 1)) + 0.5 * sum(range(1, B - m + 1))
    return (W - B * (B + 1) / 4) / math.sqrt(B * (B + 1) * (2 * B + 1) / 24)
zc = float(stats.norm.isf(0.01 / 60))
M = next(m for m in range(41) if zbest(m, 40) >= zc)
print("zc", zc, "M(40)", M, [round(zbest(m,40),2) for m in (13,16,17,20,24,30,40)])
rows = [r for p in sys.argv[1:] for r in json.load(open(p))]
import collections
c = collections.defaultdict(lambda: [0, 0])
for r in rows:
    Mb = next((m for m in range(r["B"] + 1) if zbest(m, r["B"]) >= zc), 999)
    key = (r["generator"][:4], "n<13" if r["n_rev"] < 13 else ("m<M" if r["m"] < Mb else "m>=M"))
    c[key][0] += r["named"]; c[key][1] += 1
for k in sorted(c): print(k, "named %d of %d" % tuple(c[k]))
for r in rows:
    if r["n_rev"] >= 13: print(r["generator"][:4], r["seed"], r["kind"], r["n_rev"], r["m"], r["B"], r["named"])
