"""Session 25: the bar figures of runner.py outputs. python summarise.py OUT.json [BASE.json]"""
import json, sys, importlib
sys.path.insert(0, ".")
GEN = {"independent": "plant.calibration.bench_records", "blind": "plant.calibration.blind_records"}


def figures(path):
    d = json.load(open(path))
    mod = importlib.import_module(GEN[d[0]["generator"]])
    lib, ool = set(mod.LIBRARY_KINDS), set(mod.OUT_OF_LIBRARY)
    clean = [o for o in d if not o["hidden"]]
    oo = [o for o in d if set(o["hidden"]) & ool]
    return {"n": len(d), "exact": sum(o["exact"] for o in d),
            "clean": len(clean), "clean_invented": [o["seed"] for o in clean if o["named"]],
            "ool": len(oo), "ool_no_lib": sum(not (set(o["named"]) & lib) for o in oo),
            "by_seed": {o["seed"]: o for o in d}}


a = figures(sys.argv[1])
print(sys.argv[1], f"exact {a['exact']}/{a['n']}, clean with an invented effect {len(a['clean_invented'])}/{a['clean']} "
      f"{a['clean_invented']}, out-of-library with no library kind {a['ool_no_lib']}/{a['ool']}")
if len(sys.argv) > 2:
    b = figures(sys.argv[2])
    print(sys.argv[2], f"exact {b['exact']}/{b['n']}, clean with an invented effect {len(b['clean_invented'])}/{b['clean']} "
          f"{b['clean_invented']}, out-of-library with no library kind {b['ool_no_lib']}/{b['ool']}")
    for s, o in sorted(a["by_seed"].items()):
        p = b["by_seed"].get(s)
        if p and sorted(p["named"]) != sorted(o["named"]):
            print(f"  {s} hidden {o['hidden']}: {sys.argv[2]} {p['named']} ({'OK' if p['exact'] else 'BAD'}) -> "
                  f"{sys.argv[1]} {o['named']} ({'OK' if o['exact'] else 'BAD'}); unexplained {p['unexplained']} -> {o['unexplained']}")
