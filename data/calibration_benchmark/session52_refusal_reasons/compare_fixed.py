"""Session 52: the fixed seeds 0-59 with every refusal listed, against the committed benchmark.json.

Usage (repository root): python compare_fixed.py NEW_benchmark.json — prints every record whose named
set, `unexplained`, `undecided`, key-parameter errors, exact flag or miss class differ (none expected:
the change reports, it decides nothing)."""
import json, statistics, sys

a = json.load(open("data/calibration_benchmark/benchmark.json"))["records"]
b = json.load(open(sys.argv[1]))["records"]
diff = 0
for x, y in zip(a, b):
    for k in ("named", "unexplained", "undecided", "param_errors", "exact", "miss_class"):
        if json.dumps(x[k], sort_keys=True) != json.dumps(y[k], sort_keys=True):
            diff += 1
            print(x["seed"], k, x[k], y[k])
print(f"records {len(a)} and {len(b)}; fields that differ: {diff}")
print(f"median CPU per record: committed {statistics.median(r['cpu_s'] for r in a):.2f} s, this run "
      f"{statistics.median(r['cpu_s'] for r in b):.2f} s (different runs; cost.py times the new function itself)")
