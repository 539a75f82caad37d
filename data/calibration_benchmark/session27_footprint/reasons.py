"""Session 27: why each hidden library kind was not named - the loop's own reasons (report.json
`rejected`, `undecided`), for blind records. Usage (from the tree whose loop is run):
python reasons.py OUT.json SEED ..."""
import json, os, sys
from concurrent.futures import ProcessPoolExecutor
sys.path.insert(0, os.getcwd())


def one(seed):
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "session25_sweep_guard"))
    from runner import calibrate_record   # the benchmark's own way to calibrate a record
    mod, r, rep, _ = calibrate_record("blind", str(seed))
    named = [e["kind"] for e in rep["effects"]]
    out = {"seed": seed, "hidden": list(r.hidden), "named": named, "missed": {}}
    for k in r.hidden:
        if k in mod.LIBRARY_KINDS and k not in named:
            rj = [x for x in rep["rejected"] if x["kind"] == k]
            best = max(rj, key=lambda x: x["cv_gain_pct"], default=None)
            out["missed"][k] = None if best is None else {
                "step": best["step"], "gain": best["cv_gain_pct"], "z": best["cv_z"], "reason": best["reason"]}
    return out


if __name__ == "__main__":
    rows = []
    with ProcessPoolExecutor(2) as ex:
        for o in ex.map(one, [int(a) for a in sys.argv[2:]]):
            rows.append(o)
            for k, v in o["missed"].items():
                print(o["seed"], k, "NOT TRIED" if v is None else f"gain {v['gain']:.1f} z {v['z']:.1f}: {v['reason'][:150]}", flush=True)
    json.dump(rows, open(sys.argv[1], "w"), indent=1)
