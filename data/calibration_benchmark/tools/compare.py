"""Compare two runs of the calibration loop on the same seeds: the bars' figures and every named set
that changed. One tool for every session's plan (sessions 24-26 each wrote their own judge).

Usage, from the repository root::

    python data/calibration_benchmark/tools/compare.py GENERATOR CHANGE MAIN

GENERATOR is ``blind`` or ``independent``. CHANGE and MAIN are each one or more run files joined by
``+``: the ``.json`` written by ``session25_sweep_guard/runner.py``, or its printed ``.txt`` lines
(later files win for a seed, so a re-run's lines can be merged over an unfinished run).

Figures (as in the plans' bars): exact sets; clean records with an invented effect; out-of-library
records on which no library kind was named.
"""
import importlib
import json
import re
import sys

sys.path.insert(0, ".")
GEN = {"blind": "plant.calibration.blind_records", "independent": "plant.calibration.bench_records"}


def load(paths: str) -> dict:
    """seed -> (hidden, named, exact) from ``+``-joined run files (json or printed lines)."""
    out = {}
    for p in paths.split("+"):
        if p.endswith(".json"):
            for o in json.load(open(p)):
                out[o["seed"]] = (list(o["hidden"]), list(o["named"]), bool(o["exact"]))
        else:
            for line in open(p):
                m = re.match(r"(\d+) (\[.*?\]) (\[.*?\]) (OK|BAD)", line)
                if m:
                    out[int(m.group(1))] = (eval(m.group(2)), eval(m.group(3)), m.group(4) == "OK")
    return out


def figures(d: dict, gen: str) -> dict:
    """The bars' figures of one run."""
    mod = importlib.import_module(GEN[gen])
    lib, ool = set(mod.LIBRARY_KINDS), set(mod.OUT_OF_LIBRARY)
    clean = [s for s, v in d.items() if not v[0]]
    oo = [s for s, v in d.items() if set(v[0]) & ool]
    return {"n": len(d), "exact": sum(v[2] for v in d.values()),
            "clean_invented": f"{sum(bool(d[s][1]) for s in clean)}/{len(clean)} {[s for s in clean if d[s][1]]}",
            "ool_no_library_kind": f"{sum(not (set(d[s][1]) & lib) for s in oo)}/{len(oo)}"}


def main(gen: str, change: str, base: str) -> None:
    a, b = load(change), load(base)
    common = sorted(set(a) & set(b))
    if set(a) != set(b):
        print(f"seeds only in one run are left out: change {sorted(set(a) - set(b))}, main {sorted(set(b) - set(a))}")
    a = {s: a[s] for s in common}
    b = {s: b[s] for s in common}
    print("change", figures(a, gen))
    print("main  ", figures(b, gen))
    for s in common:
        if sorted(a[s][1]) != sorted(b[s][1]):
            print(f"  {s} hidden {a[s][0]}: {b[s][1]} ({'OK' if b[s][2] else 'BAD'}) -> {a[s][1]} "
                  f"({'OK' if a[s][2] else 'BAD'})")


if __name__ == "__main__":
    if len(sys.argv) != 4 or sys.argv[1] not in GEN:
        sys.exit("usage: compare.py blind|independent CHANGE[+MORE] MAIN[+MORE]")
    main(*sys.argv[1:])
