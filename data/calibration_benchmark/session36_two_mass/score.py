"""Score the session 36 decision runs against the bars of plan_written_before_runs.md.
Usage: python score.py decision.json"""
import json, sys
import numpy as np
rows = json.load(open(sys.argv[1]))
tot_gain = tot_lost = 0
for gen in ("independent", "blind"):
    rs = [r for r in rows if r["gen"] == gen]
    named = [r for r in rs if "backlash" in r["named"] and r.get("gap_rad") is not None]
    before = [abs(r["two_mass"]["massless_gap"] / r["truth_width_rad"] - 1) for r in named]
    after = [abs(r["gap_rad"] / r["truth_width_rad"] - 1) for r in named]
    used = sum(1 for r in named if "why" not in r["two_mass"])
    gained = [r["seed"] for r, b, a in zip(named, before, after) if b > 0.3 >= a]
    lost = [r["seed"] for r, b, a in zip(named, before, after) if a > 0.3 >= b]
    tot_gain += len(gained); tot_lost += len(lost)
    print(f"{gen}: {len(rs)} records with hidden backlash, named backlash on {len(named)}; two-mass gap used on {used}")
    print(f"  within 30 %: before {sum(b <= 0.3 for b in before)}, after {sum(a <= 0.3 for a in after)}; gained {gained}, lost {lost}")
    print(f"  median |error|: before {100*np.median(before):.1f} %, after {100*np.median(after):.1f} %")
    for r, b, a in zip(named, before, after):
        tm = r["two_mass"]
        print(f"    {r['seed']:5d} {'+'.join(r['hidden']):32s} massless {100*b:6.1f} %  after {100*a:6.1f} %  "
              f"{'used' if 'why' not in tm else 'not used'}  gain {tm.get('cv_gain_pct', float('nan')):8.2f} %  "
              f"share {tm.get('load_share', float('nan')):.2f}  zeta {tm.get('damping_ratio', float('nan')):.2f}  {r['wall_s']:.0f} s")
print(f"both: gained {tot_gain}, lost {tot_lost}")
