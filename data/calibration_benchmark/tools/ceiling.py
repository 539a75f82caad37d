"""Why the misses of a decision run are missed, from what the records hold (session 41).

Nothing here runs the loop: each record is generated again (same seed, same generator) and its
*true* motion and truth are read, never the loop's output. Each missed library kind of a wrong
record gets one class, the first that applies:

A  not in the motion: asymmetric friction on a record that moves one way only, or a reversal kind
   (pre-sliding, backlash) on a record with no velocity reversal — no rule can name it;
B  a backlash gap under 5 % of the declared gear's wind-up ``2Fc/K`` (two-mass records): session 27
   measured that where wind-up/gap exceeds ~20 the gap adds under 1 % to the baseline's residual
   (a judgement from that measurement, not a loop rule; its row is apart so it can be discounted);
C  a reversal kind on a record with fewer than 13 reversals: ``loop.min_events`` at the loop's
   1 % family-wise level — the rank test cannot pass with fewer, at any gain (a limit of the rule,
   not of the physics);
D  any other miss;
and E marks a record that also names a kind it does not hide.

Reversals: the independent generator's true velocity (``velocity_rad_s``; :func:`reversals`, runs of
one sign at least 0.5 s long); the blind generator gives its own count of the trajectory's reversals
(``meta['n_reversals']``) and one-way = no reversal. The loop counts fewer on some records (its
standstill mask drops slow stairs: independent 13084 has 15, the loop sees 5).

Usage (repository root): python ceiling.py OUT.json RUN.json ... — writes the per-record classes and
prints the counts per generator, with the ceilings: how many records can have their exact set named
at all — the records with no miss of class A or B (no rule can), and with none of A, B or C (no rule
at the loop's level can; approximate: a reversal kind that also helps away from its reversals can pass
with fewer, as backlash did on development record 1048 with 11).
"""
import collections, json, os, sys
import numpy as np
sys.path.insert(0, os.getcwd())
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from jobs import GEN, map_jobs
import importlib

REV = {"presliding", "backlash"}
MIN_REVERSALS = 13        # loop.min_events(0.01, 60): the run's family-wise level over its tests
GAP_OVER_WINDUP = 0.05


#: a run of one sign shorter than this [s] is a servo overshoot, not a reversal of the trajectory
MIN_RUN_S = 0.5


def reversals(t, v):
    """(reversals, one-way) of a true velocity: the sign changes between runs of one sign at least
    :data:`MIN_RUN_S` long, on samples faster than 1e-4 of the peak speed (a staircase's slowest
    stair, 15″/s, is 2e-3 of its fastest). Counting every sign change of the samples above 1 % of
    the peak (this tool's first version) counted a servo's overshoot at every stair and turning point
    (sinusoid 13144: 15 against its 5) and dropped slow stairs."""
    m = np.abs(v) > 1e-4 * np.max(np.abs(v))
    sg, tm = np.sign(v[m]), t[m]
    ch = np.flatnonzero(sg[1:] != sg[:-1]) + 1
    seq = [sg[a] for a, b in zip(np.r_[0, ch], np.r_[ch, sg.size]) if tm[b - 1] - tm[a] >= MIN_RUN_S]
    return sum(1 for a, b in zip(seq, seq[1:]) if a != b), len(set(seq)) < 2


def motion(job):
    gen, seed = job
    r = importlib.import_module(GEN[gen]).make_record(seed)
    if gen == "independent":
        nrev, one_way = reversals(np.asarray(r.t_s, float), np.asarray(r.velocity_rad_s, float))
    else:
        nrev = int(r.meta["n_reversals"])
        one_way = nrev == 0
    tm, ratio = r.meta.get("two_mass"), None
    if tm and "backlash" in r.hidden:
        fc = r.meta.get("coulomb_nm") or r.meta.get("fc")
        ratio = r.truth["backlash"]["width_rad"] / (2 * fc / tm["stiffness_nm_rad"])
    return {"generator": gen, "seed": seed, "n_reversals": nrev, "one_way": one_way, "gap_over_windup": ratio}


def classify(r, m, lib):
    missing = {h for h in r["hidden"] if h in lib} - set(r["named"])
    tags = set()
    for h in missing:
        if (h == "asymmetric_friction" and m["one_way"]) or (h in REV and m["n_reversals"] == 0):
            tags.add("A")
        elif h == "backlash" and m["gap_over_windup"] is not None and m["gap_over_windup"] < GAP_OVER_WINDUP:
            tags.add("B")
        elif h in REV and m["n_reversals"] < MIN_REVERSALS:
            tags.add("C")
        else:
            tags.add("D")
    if set(r["named"]) - set(r["hidden"]):
        tags.add("E")
    return "".join(sorted(tags))


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    runs = [r for p in sys.argv[2:] for r in json.load(open(p))]
    ms = {(m["generator"], m["seed"]): m for m in map_jobs(motion, [(r["generator"], r["seed"]) for r in runs])}
    out = []
    for gen in GEN:
        lib = set(importlib.import_module(GEN[gen]).LIBRARY_KINDS)
        rs = [r for r in runs if r["generator"] == gen]
        if not rs:
            continue
        c = collections.Counter()
        for r in rs:
            m = ms[(gen, r["seed"])]
            cls = "exact" if r["exact"] else classify(r, m, lib)
            c[cls] += 1
            out.append({**m, "hidden": r["hidden"], "named": r["named"], "class": cls})
        n = len(rs)
        ab = n - sum(v for k, v in c.items() if k != "exact" and set(k) & set("AB"))
        abc = n - sum(v for k, v in c.items() if k != "exact" and set(k) & set("ABC"))
        print(f"{gen}: {n} records; " + ", ".join(f"{k} {v}" for k, v in sorted(c.items(), key=lambda x: -x[1])))
        print(f"  exact sets nameable at all (no A or B miss): {ab}/{n} = {100 * ab / n:.1f} %; at the loop's level "
              f"(no A, B or C miss): {abc}/{n} = {100 * abc / n:.1f} %; named: {c['exact']}/{n} = {100 * c['exact'] / n:.1f} %")
    json.dump(out, open(sys.argv[1], "w"), indent=0)
