"""Session 26: compare the change's runs with main's (named sets and the bars' figures); run from the
repository root: python data/calibration_benchmark/session26_position_friction/judge.py [PREFIX]
(PREFIX: ``change_`` for the second change, the default, or ``delay_`` for the third)."""
import importlib, json, re, sys
sys.path.insert(0, ".")
D = "data/calibration_benchmark/session26_position_friction/"
S = "data/calibration_benchmark/session25_moving_guard/"
PREFIX = sys.argv[1] if len(sys.argv) > 1 else "change_"
GEN = {"blind": "plant.calibration.blind_records", "independent": "plant.calibration.bench_records"}


def load(p):
    return {o["seed"]: (o["hidden"], o["named"], bool(o["exact"])) for o in json.load(open(p))}


def parse(p):
    """A runner's printed lines: seed -> (hidden, named, exact)."""
    out = {}
    try:
        for line in open(p):
            m = re.match(r"(\d+) (\[.*?\]) (\[.*?\]) (OK|BAD)", line)
            if m:
                out[int(m.group(1))] = (eval(m.group(2)), eval(m.group(3)), m.group(4) == "OK")
    except FileNotFoundError:
        pass
    return out


def figs(d, gen):
    mod = importlib.import_module(GEN[gen]); lib, ool = set(mod.LIBRARY_KINDS), set(mod.OUT_OF_LIBRARY)
    clean = [s for s, v in d.items() if not v[0]]
    oo = [s for s, v in d.items() if set(v[0]) & ool]
    return dict(n=len(d), exact=sum(v[2] for v in d.values()), clean_invented=[s for s in clean if d[s][1]],
                n_clean=len(clean), ool_no_library_kind=sum(not (set(d[s][1]) & lib) for s in oo), n_ool=len(oo))


for name, gen, mainp in [("blind_320_379", "blind", D + "main_blind_320_379.json"),
                         ("fresh_3000_3059", "independent", None), ("dev_1000_1059", "independent", None)]:
    try:
        a = load(D + f"{PREFIX}{name}.json")
    except FileNotFoundError:
        print(name, "change: not run"); continue
    print(name, "change", figs(a, gen))
    if mainp is None:  # main = HEAD = session 25's kept change: its runs, merged as session 25's judge.py did
        b = parse(S + f"change_{name}.txt")
        b.update(parse(S + f"rerun_{name}.txt"))
        b.update(parse(S + f"rerun2_{name}.txt"))
        print("   main  ", figs(b, gen))
    else:
        b = load(mainp)
        print("   main  ", figs(b, gen))
    for s in sorted(a):
        if s in b and sorted(a[s][1]) != sorted(b[s][1]):
            print("   diff", s, a[s][0], b[s][1], "->", a[s][1], "OK" if a[s][2] else "BAD")
