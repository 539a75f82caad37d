"""Session 27: found / total per kind in the footprint bins fixed in the plan (no loop is run).

Usage: python summarise.py footprint_blind.json > footprint_summary.md
"""
import json
import sys
from collections import defaultdict
from pathlib import Path

HERE = Path(__file__).resolve().parent
#: HEAD's named sets before session 27's change (corrected after the first summary: the committed
#: session-25 runs of 200-259 and 260-319 predate that session's second change; 200-259 was re-run in
#: session 27, 260-319 was re-run by session 25 itself in its change_/rerun_ files)
B = HERE.parent
RUNS = "+".join(str(p) for p in [
    B / "session26_position_friction" / "head_blind_0_59.json",
    B / "session26_position_friction" / "head_blind_100_159.json",
    B / "session27_edge_peak" / "main_blind_200_259_rerun.json",
    B / "session25_moving_guard" / "main_blind_260_319.json",
    B / "session25_moving_guard" / "change_blind_260_319.txt",
    B / "session25_moving_guard" / "rerun_blind_260_319.txt",
    B / "session25_moving_guard" / "rerun2_blind_260_319.txt",
    B / "session26_position_friction" / "main_blind_320_379.json"])
BINS = [(-1e9, 1.0, "< 1 %"), (1.0, 3.0, "1–3 %"), (3.0, 10.0, "3–10 %"), (10.0, 30.0, "10–30 %"),
        (30.0, 1e9, "≥ 30 %")]
KINDS = ["asymmetric_friction", "position_periodic", "gravity_imbalance", "time_periodic", "presliding", "backlash"]
MIN_REVERSALS = 13


def bin_of(x):
    return next(label for lo, hi, label in BINS if lo <= x < hi)


def main(path):
    fp = json.load(open(path))
    sys.path.insert(0, str(B / "tools"))
    from compare import load
    runs = {seed: {"hidden": h, "named": n, "exact": e, "undecided": []} for seed, (h, n, e) in load(RUNS).items()}
    for f in RUNS.split("+"):   # the printed lines carry no undecided kinds; the json files do
        if f.endswith(".json"):
            for o in json.load(open(f)):
                runs[o["seed"]]["undecided"] = o["undecided"]
    rows = []
    for f in fp:
        run = runs[f["seed"]]
        assert sorted(run["hidden"]) == sorted(f["hidden"]), f["seed"]
        rows.append({**f, "found": f["kind"] in run["named"], "exact": run["exact"], "named": run["named"],
                     "undecided": run["undecided"]})
    print(f"# Footprint of the hidden library effects on {len(runs)} blind records (HEAD's named sets)\n")
    print("Found / total per kind and excess bin (the baseline residual the effect adds):\n")
    print("| kind | " + " | ".join(b[2] for b in BINS) + " | all |")
    print("|---|" + "---|" * (len(BINS) + 1))
    tot = defaultdict(lambda: [0, 0])
    for k in KINDS + ["all"]:
        cells = []
        for lo, hi, label in BINS:
            sel = [r for r in rows if (k == "all" or r["kind"] == k) and lo <= r["excess_pct"] < hi]
            cells.append(f"{sum(r['found'] for r in sel)}/{len(sel)}" if sel else "–")
        sel = [r for r in rows if k == "all" or r["kind"] == k]
        print(f"| {k} | " + " | ".join(cells) + f" | {sum(r['found'] for r in sel)}/{len(sel)} |")
    print("\nReversal kinds, split by the reversals of the commanded motion (the rule needs "
          f"{MIN_REVERSALS}), excess ≥ 10 %:\n")
    print("| kind | reversals < 13 | reversals ≥ 13 |")
    print("|---|---|---|")
    for k in ("presliding", "backlash"):
        c = []
        for few in (True, False):
            sel = [r for r in rows if r["kind"] == k and r["excess_pct"] >= 10
                   and (r["n_reversals"] < MIN_REVERSALS) == few]
            c.append(f"{sum(r['found'] for r in sel)}/{len(sel)}")
        print(f"| {k} | {c[0]} | {c[1]} |")
    print("\nMisses with an excess ≥ 10 % (the loop's failures, not the records'):\n")
    print("| seed | kind | excess % | Δ⊥ share % | reversals | trajectory | chain | wind-up/gap | named | undecided |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in sorted(rows, key=lambda r: (r["kind"], -r["excess_pct"])):
        if not r["found"] and r["excess_pct"] >= 10:
            wg = f"{r['windup_over_gap']:.1f}" if "windup_over_gap" in r else ""
            print(f"| {r['seed']} | {r['kind']} | {r['excess_pct']:.1f} | {r['share_pct']:.1f} | {r['n_reversals']} | "
                  f"{r['trajectory']} | {r['chain']} | {wg} | {', '.join(r['named']) or '–'} | "
                  f"{', '.join(r['undecided']) or '–'} |")
    print("\nNegative excess (the machine without the effect is harder for the baseline):\n")
    for r in rows:
        if r["excess_pct"] < 0:
            print(f"- {r['seed']} {r['kind']}: {r['excess_pct']:.1f} %, found: {r['found']}")


if __name__ == "__main__":
    main(sys.argv[1])
