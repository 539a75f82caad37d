"""Session 59's pre-screen: the records whose periodic-motion fundamental the second change moves (no
loop run). The change acts on the loop only through that fundamental (the phase guard's), so a record
whose fundamental does not move runs the same computation in both trees.

Usage (in the change's tree, 05f8251 — its ``_periodic_search`` returns four values; the loop at HEAD
is main's): python prescreen.py LO HI — both generators, seeds LO..HI-1; prints each record whose
fundamental moves (main's: the first search, the sinusoid search only when that finds none; the
change's: ``periodic_motion``) and the count. Session 33's ``fundamental_filter.py`` does the same from
two trees. Rewritten after the run onto ``tools/jobs.py`` (the first form, as run, wrote its own pool
and generator table: ``git show 05f8251:data/calibration_benchmark/session59_sinusoid_floor/prescreen.py``);
the output is the same.
"""
import importlib, os, pathlib, sys, tempfile
sys.path.insert(0, os.getcwd())
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "tools"))
from jobs import GEN, map_jobs


def one(job):
    from plant.calibration import loop
    from plant.calibration.fit import prepare
    from plant.calibration.report import load_record
    gen, seed = job
    r = importlib.import_module(GEN[gen]).make_record(seed)
    d = pathlib.Path(tempfile.mkdtemp()); r.write_csv(d / "rec.csv")
    prep = prepare(load_record(str(d / "rec.csv")))
    t, v, v0, var, dt = loop._velocity_rows(prep)
    old = loop._periodic_search(t, v, v0, var, dt, loop.PERIODIC_MIN_CYCLES, loop.PERIODIC_MAX_HARMONICS)[:3]
    if old[0] is None:
        old = loop._periodic_search(t, v, v0, var, dt, loop.PERIODIC_MIN_CYCLES_SINUSOID, loop.PHASE_HARMONICS)[:3]
    new = loop.periodic_motion(prep)
    ti = r.meta.get("trajectory_info") or {}
    true_f = 1.0 / ti["period_s"] if isinstance(ti, dict) and ti.get("period_s") else None
    return gen, seed, r.meta.get("trajectory"), true_f, old, new, list(r.hidden)


if __name__ == "__main__":
    jobs = [(g, s) for g in ("independent", "blind") for s in range(int(sys.argv[1]), int(sys.argv[2]))]
    n = 0
    for gen, seed, tr, tf, old, new, hid in map_jobs(one, jobs):
        if old[0] != new[0]:
            n += 1
            print(gen, seed, tr, hid, "true", tf and round(tf, 5), "old", old[0] and round(old[0], 5), round(old[1], 3),
                  old[2], "new", new[0] and round(new[0], 5), round(new[1], 4), new[2], flush=True)
    print("changed", n, "of", len(jobs))
