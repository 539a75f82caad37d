"""Session 27: why each hidden library kind was not named - the loop's own reasons (report.json
`rejected`, `undecided`), for blind records. Usage (from the tree whose loop is run):
python reasons.py OUT.json SEED ..."""
import json, os, sys, tempfile, pathlib
from concurrent.futures import ProcessPoolExecutor
sys.path.insert(0, os.getcwd())


def one(seed):
    from plant.calibration import blind_records as br
    from plant.calibration.report import calibrate
    r = br.make_record(seed)
    d = pathlib.Path(tempfile.mkdtemp(prefix=f"s27_r_{seed}_"))
    r.write_csv(d / "rec.csv")
    K = r.meta.get("two_mass", {}).get("stiffness_nm_rad")
    rep = calibrate(str(d / "rec.csv"), str(d / "out"), plots=False, gear_stiffness=K)
    named = [e["kind"] for e in rep["effects"]]
    out = {"seed": seed, "hidden": list(r.hidden), "named": named, "missed": {}}
    for k in r.hidden:
        if k in br.LIBRARY_KINDS and k not in named:
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
