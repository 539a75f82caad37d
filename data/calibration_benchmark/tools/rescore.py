"""Score stored runs again with :func:`host.calibration_benchmark.score` (session 41).

Two uses:

* ``python rescore.py benchmark DIR`` — recompute the summary of ``DIR/benchmark.json`` from its
  stored per-record results (what ran; nothing is calibrated again; a record without its true motion
  gets it from its generator and seed, :func:`host.calibration_benchmark.record_motion`) and rewrite
  ``benchmark.json`` and ``benchmark.md``. Refuses to write if any figure the stored summary already had changes.
* ``python rescore.py runs OUT.md RUN.json ...`` — the runner outputs of the sessions' decision runs
  (``flag_runner.py``: one list of records, both generators) scored per generator, the markdown
  summary and per-kind table written to OUT.md.

Run from the repository root (``host`` must import).
"""
import copy, json, os, sys
sys.path.insert(0, os.getcwd())
from host.calibration_benchmark import GENERATORS, _clean, generator, markdown, per_kind_table, record_motion, score


def benchmark(d):
    p = os.path.join(d, "benchmark.json")
    b = json.load(open(p))
    gen = generator(b["generator"])
    for r in b["records"]:
        if "motion" not in r:   # a record of a run before session 41: its true motion, from the same seed
            r["motion"] = record_motion(gen.make_record(int(r["seed"])))
    new = score(copy.deepcopy(b["records"]), tuple(gen.OUT_OF_LIBRARY))
    for k, v in b["summary"].items():
        if json.dumps(v, sort_keys=True, default=str) != json.dumps(new[k], sort_keys=True, default=str):
            sys.exit(f"{p}: summary field {k!r} differs when scored again; not rewritten")
    added = sorted(set(new) - set(b["summary"])) or ["none"]
    b["summary"] = new
    open(p, "w").write(json.dumps(_clean(b), indent=2))   # as run_benchmark writes it
    open(os.path.join(d, "benchmark.md"), "w").write(markdown(b))
    print(f"rewrote {p} and benchmark.md (summary fields added: {', '.join(added)})")


def runs(out_md, paths):
    recs = [r for p in paths for r in json.load(open(p))]
    L = []
    for gen in GENERATORS:
        rs = [dict(r, undecided=[{"kind": k} for k in r["undecided"]], wall_s=None) for r in recs
              if r["generator"] == gen]
        if not rs:
            continue
        s = score(rs, tuple(generator(gen).OUT_OF_LIBRARY))
        seeds = sorted(r["seed"] for r in rs)
        L += [f"## {gen}: {len(rs)} records, seeds {seeds[0]}–{seeds[-1]} ({', '.join(paths)})", "",
              f"- exact set {s['n_exact']}/{s['n_records']} = {100 * s['exact_set_accuracy']:.1f} %; clean with an invented "
              f"effect {len(s['clean']['false_positive_seeds'])}/{s['clean']['n']}; out-of-library with no library kind "
              f"{s['out_of_library']['ok']}/{s['out_of_library']['n']}; wrong only by undecided kinds "
              f"{s['missed_reported_undecided']['n']}", ""] + per_kind_table(s) + [""]
    open(out_md, "w").write("\n".join(L))
    print("\n".join(L))


if __name__ == "__main__":
    a = sys.argv[1:]
    if len(a) >= 2 and a[0] == "benchmark":
        benchmark(a[1])
    elif len(a) >= 3 and a[0] == "runs":
        runs(a[1], a[2:])
    else:
        sys.exit(__doc__)
