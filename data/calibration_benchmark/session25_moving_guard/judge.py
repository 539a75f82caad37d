"""Session 25: merge the change's partial runs (change_, rerun_, rerun2_) and compare with main; run from the repository root."""
import re, json, sys
sys.path.insert(0, ".")
import importlib
D = "data/calibration_benchmark/session25_moving_guard/"
S = "data/calibration_benchmark/session25_sweep_guard/"
GEN = {"blind": "plant.calibration.blind_records", "independent": "plant.calibration.bench_records"}
def parse(p):
    out = {}
    try:
        for l in open(p):
            m = re.match(r"(\d+) (\[.*?\]) (\[.*?\]) (OK|BAD)", l)
            if m: out[int(m.group(1))] = (eval(m.group(2)), eval(m.group(3)), m.group(4) == "OK")
    except FileNotFoundError: pass
    return out
def base(p):
    return {o["seed"]: (o["hidden"], o["named"], bool(o["exact"])) for o in json.load(open(p))}
def figs(d, gen):
    mod = importlib.import_module(GEN[gen]); lib, ool = set(mod.LIBRARY_KINDS), set(mod.OUT_OF_LIBRARY)
    clean = [s for s, v in d.items() if not v[0]]
    oo = [s for s, v in d.items() if set(v[0]) & ool]
    return dict(n=len(d), exact=sum(v[2] for v in d.values()), clean_inv=[s for s in clean if d[s][1]], nclean=len(clean),
                ool_nolib=sum(not (set(d[s][1]) & lib) for s in oo), nool=len(oo))
for name, gen, basep in [("blind_260_319", "blind", D + "main_blind_260_319.json"),
                         ("fresh_3000_3059", "independent", S + "change_fresh_3000_3059.json"),
                         ("dev_1000_1059", "independent", S + "change_dev_1000_1059.json")]:
    a = parse(D + f"change_{name}.txt"); a.update(parse(D + f"rerun_{name}.txt")); a.update(parse(D + f"rerun2_{name}.txt"))
    b = base(basep)
    print(name, "change", figs(a, gen), "\n   main ", figs(b, gen))
    for s in sorted(a):
        if sorted(a[s][1]) != sorted(b[s][1]): print("   diff", s, a[s][0], b[s][1], "->", a[s][1], "OK" if a[s][2] else "BAD")
