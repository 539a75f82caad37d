"""Session 60: the two probes' tables from their outputs (used records 27010-27159; nothing here runs the loop).

Usage (repository root): python data/calibration_benchmark/session60_probes/summarize.py
1. `lineres_used.json` (`probe_lineres.py`, main's loop): every candidate that passes the rank test at its
   run's level and that the line-resolution rule refuses, with its size in quanta and whether the record hides
   that kind at that frequency (within 3 %).
2. `il40_used.json` (`probe_interleave.py`): named sets with interleaved folds against main's on the same
   records (session 59's `change_F.json`, whose named sets are main's on every record).
"""
import json, pathlib
here = pathlib.Path(__file__).resolve().parent
rows = []
for r in json.load(open(here / "lineres_used.json")):
    lv = r["level"] or 3.59
    for x in r["refused"]:
        if not (x["cv_gain_pct"] > 0 and x["cv_z"] >= lv):
            continue
        f = x["line"]["frequency"] if x.get("line") else None
        tr = r["truth"].get(x["kind"], {})
        tf = tr.get("frequency_hz") or (1 / tr["period_rad"] if tr.get("period_rad") else None)
        what = "hidden" if tf and f and abs(f / tf - 1) < 0.03 else ("other line of that kind hidden" if tf else "not hidden")
        rows.append((r["generator"], r["seed"], x["kind"], x["step"], x["cv_gain_pct"], x["cv_z"], x["n_q"],
                     "+".join(x["rules"]), what))
print("1. candidates passing the rank test that the line-resolution rule refuses")
print("| generator | seed | kind | step | gain % | z | quanta | rules | hidden? |\n|---|---|---|---|---|---|---|---|---|")
for g, s, k, st, gain, z, nq, rules, what in rows:
    print(f"| {g} | {s} | {k} | {st} | {gain:.1f} | {z:.2f} | {nq} | {rules} | {what} |")
only = [r for r in rows if r[7] == "line_resolution"]
big = [r for r in only if r[6] is not None and r[6] >= 5]
print(f"\n{len(rows)} refusals on {len({(r[0], r[1]) for r in rows})} records; by this rule alone {len(only)} "
      f"({sum(r[8] == 'hidden' for r in only)} hidden); alone and at 5-10 quanta: "
      + ", ".join(f"{r[0]} {r[1]} {r[2]} {r[6]} q ({r[8]})" for r in big))

main = {(r["generator"], r["seed"]): r for r in json.load(open(here.parent / "session59_out_of_library" / "change_F.json"))}
il = json.load(open(here / "il40_used.json"))
print("\n2. interleaved folds (40 blocks, fold = block mod 8) against main")
for r in il:
    m = main[(r["generator"], r["seed"])]
    if set(m["named"]) != set(r["named"]):
        print(f"  {r['generator']} {r['seed']} hidden {r['hidden']}: main {m['named']} ({'exact' if m['exact'] else 'wrong'})"
              f" -> interleaved {r['named']} ({'exact' if r['exact'] else 'wrong'})")
for g in ("independent", "blind"):
    rs = [r for r in il if r["generator"] == g]
    print(f"  {g}: main {sum(main[(g, r['seed'])]['exact'] for r in rs)}/{len(rs)}, interleaved {sum(r['exact'] for r in rs)}/{len(rs)}")
