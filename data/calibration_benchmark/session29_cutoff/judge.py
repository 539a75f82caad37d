"""Session 29: the bars of plan_written_before_runs.md, from the run files. Usage: python judge.py"""
import json
import statistics
from pathlib import Path

HERE = Path(__file__).parent
LIB = {"asymmetric_friction", "position_periodic", "gravity_imbalance", "presliding", "backlash", "time_periodic"}


def rows(path):
    return {r["seed"]: r for r in json.loads(Path(path).read_text())}


def exact(r):
    lib_hidden = {h for h in r["hidden"] if h in LIB}
    return sorted(set(r["named"])) == sorted(lib_hidden) and (lib_hidden or not r["named"])


def summary(rs, seeds, label):
    ex = [s for s in seeds if exact(rs[s])]
    clean = sum(len(rs[s]["named"]) for s in seeds if not rs[s]["hidden"])
    ool = [s for s in seeds if rs[s]["hidden"] and not set(rs[s]["hidden"]) & LIB and set(rs[s]["named"]) & LIB]
    errs = []
    for s in seeds:
        b = rs[s]["baseline"]["params"]
        errs += [abs(b["coulomb_nm"] / rs[s]["fc"] - 1) * 100, abs(b["viscous_nm_s_rad"] / rs[s]["fv"] - 1) * 100]
    print(f"{label}: exact {len(ex)}/{len(seeds)} {ex}; effects on clean {clean}; ool with a library kind {len(ool)} {ool}; "
          f"median |Fc|,|Fv| error {statistics.median(errs):.3f} %; wall {[round(rs[s]['wall_s']) for s in seeds]}")


main28 = rows(HERE.parent / "session28_rest_mask" / "long_variant.json")
main_fresh = rows(HERE / "main_fresh.json")
change = rows(HERE / "change_all.json")
bar1 = [0, 1, 2, 3, 4, 5, 45, 46, 48, 50]
fresh = [6, 7, 8, 9, 40, 49]
print("bar 1 (session 28's ten long records)")
summary(main28, bar1, "  main (session 28's long_variant.json)")
summary(change, bar1, "  change")
print("bar 2 (six fresh long records)")
summary(main_fresh, fresh, "  main")
summary(change, fresh, "  change")
print("check: seed 45 on HEAD", main_fresh[45]["named"], main_fresh[45]["baseline"]["params"] == main28[45]["baseline"]["params"])
print("info: seed 38 change", change[38]["named"], round(change[38]["wall_s"]), "s", round(change[38]["peak_rss_mb"]), "MB")
