"""The calibration benchmark: the loop on records from the independent generator, scored.

A harness, so it lives in host/: it measures wall time and peak memory of each calibration
(plant/ never reads the wall clock).

:func:`run_benchmark` writes each record of :mod:`plant.calibration.bench_records` as CSV, runs
``calibrate`` on it (CSV reader included, no plots) in a fresh child process — so that the peak
resident memory of one calibration can be read from the operating system — and scores what the
loop named against what was hidden:

* **confusion matrix**: rows = hidden kinds (``clean`` for a clean record, out-of-library names),
  columns = named kinds (``none`` when nothing was named); one count per (hidden, named) pair of a
  record;
* **exact-set accuracy**: named library kinds == hidden library kinds (out-of-library records:
  nothing named);
* **false positives** on clean and on out-of-library records (any kind named), and for
  out-of-library records whether ``unexplained`` carries the structure;
* **misses the record could not decide**: records wrong only by missing effects that the report
  lists in ``undecided`` (a reversal effect on too few reversals for the rule to pass, with the
  reversals and the number needed; or a term the phase guard refuses on a periodic motion) — still
  counted as wrong;
* **per kind, when named and when hidden**: of the records that name a library kind, how many hide
  it (what an engineer can read into a report that names it: a precision), and of the records that
  hide it, how many name it (a recall); session 41 found that on never-used records pre-sliding is
  named almost as often where it is not hidden as where it is, which the exact-set figure does not show;
* **what the records allow** (session 41): each record's true motion (:func:`record_motion`, read
  from the generator's record, never from the loop) puts each missed kind in a class
  (:func:`miss_class`: A not in the motion, B a gap hidden by the gear's wind-up, C a reversal kind
  on fewer reversals than the rule can ever pass, D other; E marks a kind named and not hidden), and
  the summary gives how many records could be named exactly at all (no A or B miss) and at the
  loop's level (no A, B or C miss) beside how many were;
* **key-parameter errors** of correctly named kinds (period/frequency: relative error, target
  3 %; amplitudes, backlash width, asymmetric viscous coefficients: 30 %; σ0 reported, no target);
* **time and peak memory** per record and per sample.

Optionally a long record (``long_samples``, e.g. 10⁶) measures the hour-long-log case.
"""

from __future__ import annotations

import json
import math
import multiprocessing as mp
import resource
import time
from pathlib import Path
from typing import Any

import numpy as np

from plant.calibration.bench_records import CI_SEEDS, DEFAULT_SEEDS, LIBRARY_KINDS, OUT_OF_LIBRARY, make_record
from plant.calibration.loop import REVERSAL_KINDS, LoopConfig, min_events
from plant.effects import EFFECT_KINDS

__all__ = ["run_benchmark", "score", "record_motion", "miss_class", "MISS_CLASSES", "KEY_PARAMS", "TARGETS", "DEFAULT_SEEDS", "CI_SEEDS", "GENERATORS", "generator"]

#: The record generators the benchmark can score, by ``--generator`` name: the module (it imports
#: nothing from ``plant``) and what it is.
#:
#: * ``independent``: :mod:`plant.calibration.bench_records`, written from the equations for this
#:   benchmark (session 3). The loop's rules were developed on its seeds 1000–1059 and checked on
#:   0–59 and fresh seeds, so its figures carry that history.
#: * ``blind``: :mod:`plant.calibration.blind_records`, written in session 24 by a helper that was
#:   not allowed to read the calibration code, the other generator or docs/calibration.md — only the
#:   issue's physics and the CSV format. No rule of the loop was developed or tuned on it, so its
#:   figures are the closest the project has to "records it did not make" (docs/calibration.md,
#:   "Session 24").
GENERATORS: dict[str, str] = {
    "independent": "plant.calibration.bench_records",
    "blind": "plant.calibration.blind_records",
}


def generator(name: str) -> Any:
    """The generator module called ``name`` (a key of :data:`GENERATORS`).

    Raises
    ------
    ValueError
        An unknown name (the message lists the known ones), or a generator whose library kinds
        differ from the ``plant.effects`` registry.
    """
    import importlib

    if name not in GENERATORS:
        raise ValueError(f"--generator {name!r}: expected one of {sorted(GENERATORS)}")
    mod = importlib.import_module(GENERATORS[name])
    if set(mod.LIBRARY_KINDS) != set(EFFECT_KINDS):
        raise ValueError(f"benchmark generator {name!r} kinds {sorted(mod.LIBRARY_KINDS)} differ from plant.effects "
                         f"{sorted(EFFECT_KINDS)}")
    return mod

#: Key parameters per kind and the relative tolerance the issue sets (None: reported, no target).
KEY_PARAMS: dict[str, dict[str, float | None]] = {
    "position_periodic": {"period_rad": 0.03, "amplitude_nm": 0.30},
    "time_periodic": {"frequency_hz": 0.03, "amplitude_nm": 0.30},
    "gravity_imbalance": {"amplitude_nm": 0.30},
    # width_rad: the loop's fitted width (the massless description's) against the generator's gap;
    # gap_rad: the gap the report gives with the drive's stiffness given (as an engineer has it from
    # the drive's design; here the generator's) — the width the plant file gets (session 37: the
    # two-mass refit where it predicts better, else the massless gap). Both scored against 30 %.
    "backlash": {"width_rad": 0.30, "gap_rad": 0.30},
    "asymmetric_friction": {"viscous_pos_nm_s_rad": 0.30, "viscous_neg_nm_s_rad": 0.30},
    "presliding": {"sigma0_nm_rad": None},
}

#: A run of one sign of the true velocity shorter than this [s] is a servo's overshoot at a stair or
#: a turning point, not a reversal of the trajectory (:func:`record_motion`). Assumed: 0.5 s, several
#: closed-loop settling times of both generators' velocity loops (bandwidths of 5–40 Hz). Measured on
#: independent 13060–13119 (session 41): 0.25 s counts overshoots on 6 of 60 records; 1 s changes 1
#: (staircase 13115, 13 → 12 reversals, at the rule's limit).
MIN_RUN_S = 0.5
#: A backlash gap under this fraction of the declared gear's wind-up ``2Fc/K`` is class B
#: (:func:`miss_class`). Assumed from session 27's measurement (docs/calibration.md): where the
#: wind-up exceeds ~20 gaps, the gap adds under 1 % to the baseline's residual. A judgement, so B is
#: reported apart from A.
GAP_OVER_WINDUP_MIN = 0.05
#: The fewest reversals at which a reversal kind can pass the loop's rank test at all (13): the loop's
#: family-wise level over 12 candidates × its most effects, as its Stribeck decision counts the tests
#: — the rank test's limit (class C), not physics. Since session 61 a reversal kind on fewer may still
#: pass on its reversals' loss ratios (``loop.unit_compare``), so the ceiling "at the rule's level" is
#: the rank test's, not a bound on what the loop names.
MIN_REVERSALS = min_events(LoopConfig().family_alpha, 12 * LoopConfig().max_effects)
#: Classes of a missed kind (:func:`miss_class`), in the order they are tried; E marks a wrong name.
MISS_CLASSES = {
    "A": "not in the motion (asymmetric friction on one-way motion, a reversal kind without a reversal)",
    "B": f"a backlash gap under {GAP_OVER_WINDUP_MIN:.0%} of the declared gear's wind-up 2Fc/K",
    "C": f"a reversal kind on fewer than {MIN_REVERSALS} reversals (the 1 % rank test cannot pass; only the reversals' t-test can)",
    "D": "another miss",
    "E": "a kind named that the record does not hide",
}


def record_motion(rec: Any) -> dict[str, Any]:
    """What a benchmark record's true motion holds, for :func:`miss_class` (session 41).

    Parameters
    ----------
    rec : generator record
        With ``t_s`` [s] and ``velocity_rad_s`` [rad/s] (shape (N,); the independent generator's true
        velocity), or ``meta['n_reversals']`` (the blind generator's count of its trajectory's
        reversals); ``meta['two_mass']['stiffness_nm_rad']``, ``meta['coulomb_nm']`` or
        ``meta['fc']`` [N·m] and ``truth['backlash']['width_rad']`` for a two-mass record with backlash.

    Returns
    -------
    dict
        ``n_reversals`` (sign changes between runs of one sign at least :data:`MIN_RUN_S` long, on
        samples faster than 1e-4 of the peak speed — a staircase's slowest stair, 15″/s, is 2e-3 of
        its fastest), ``one_way`` (bool) and ``gap_over_windup`` (backlash gap / ``2Fc/K``; None
        unless a two-mass record hides backlash).

    Raises
    ------
    KeyError
        A record with neither a true velocity nor ``meta['n_reversals']``, or a two-mass backlash
        record without its stiffness, Coulomb level or gap.
    """
    v = getattr(rec, "velocity_rad_s", None)
    if v is not None:
        t, v = np.asarray(rec.t_s, float), np.asarray(v, float)
        m = np.abs(v) > 1e-4 * float(np.max(np.abs(v)))
        sg, tm = np.sign(v[m]), t[m]
        ch = np.flatnonzero(sg[1:] != sg[:-1]) + 1
        runs = [sg[a] for a, b in zip(np.r_[0, ch], np.r_[ch, sg.size]) if b > a and tm[b - 1] - tm[a] >= MIN_RUN_S]
        n_rev = sum(1 for a, b in zip(runs, runs[1:]) if a != b)
        one_way = len(set(runs)) < 2
    else:
        n_rev = int(rec.meta["n_reversals"])
        one_way = n_rev == 0
    ratio = None
    tm2 = rec.meta.get("two_mass")
    if tm2 and "backlash" in rec.hidden:
        fc = rec.meta.get("coulomb_nm") or rec.meta.get("fc")
        ratio = float(rec.truth["backlash"]["width_rad"] / (2.0 * fc / tm2["stiffness_nm_rad"]))
    return {"n_reversals": int(n_rev), "one_way": bool(one_way), "gap_over_windup": ratio}


def miss_class(r: dict[str, Any]) -> str:
    """The classes (:data:`MISS_CLASSES`) of a scored record's misses, e.g. ``"C"``, ``"DE"``; ``""``
    when its set is exact. ``r``: ``hidden``, ``named`` and ``motion`` (:func:`record_motion`)."""
    m = r["motion"]
    hidden_lib = {h for h in r["hidden"] if h in LIBRARY_KINDS}
    tags = set()
    for h in hidden_lib - set(r["named"]):
        if (h == "asymmetric_friction" and m["one_way"]) or (h in REVERSAL_KINDS and m["n_reversals"] == 0):
            tags.add("A")
        elif h == "backlash" and m["gap_over_windup"] is not None and m["gap_over_windup"] < GAP_OVER_WINDUP_MIN:
            tags.add("B")
        elif h in REVERSAL_KINDS and m["n_reversals"] < MIN_REVERSALS:
            tags.add("C")
        else:
            tags.add("D")
    if set(r["named"]) - hidden_lib:
        tags.add("E")
    return "".join(sorted(tags))


#: Targets of issue 7 (fractions).
TARGETS = {"exact_set": 0.90, "out_of_library_ok": 0.90, "clean_false_positives": 0}


def _rss_mb() -> float:
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * resource.getpagesize() / 2**20
    except OSError:  # pragma: no cover - non-Linux
        return float("nan")


def _child(conn, csv_path: str, out_dir: str, gear_stiffness: float | None) -> None:  # pragma: no cover - child process
    try:
        from plant.calibration.report import calibrate

        rss0 = _rss_mb()
        ru0 = resource.getrusage(resource.RUSAGE_SELF)
        cpu0 = ru0.ru_utime + ru0.ru_stime
        t0 = time.perf_counter()
        rep = calibrate(csv_path, out_dir, plots=False, gear_stiffness=gear_stiffness)
        wall = time.perf_counter() - t0
        ru = resource.getrusage(resource.RUSAGE_SELF)
        peak = ru.ru_maxrss / 1024.0
        conn.send({"ok": True, "wall_s": wall, "cpu_s": ru.ru_utime + ru.ru_stime - cpu0, "peak_rss_mb": peak, "rss_start_mb": rss0,
                   "effects": [{"kind": e["kind"], "params": e["params"],
                                **({"gap_rad": e["gap_rad"]} if "gap_rad" in e else {})} for e in rep["effects"]],
                   "unexplained": rep["unexplained"], "undecided": rep.get("undecided", []), "conclusion": rep["conclusion"],
                   "competition": rep.get("competition", [])})
    except Exception as exc:  # report, do not hang the parent
        conn.send({"ok": False, "error": f"{type(exc).__name__}: {exc}"})
    finally:
        conn.close()


def _calibrate_isolated(csv_path: Path, out_dir: Path, gear_stiffness: float | None = None) -> dict[str, Any]:
    ctx = mp.get_context("fork")
    a, b = ctx.Pipe(duplex=False)
    p = ctx.Process(target=_child, args=(b, str(csv_path), str(out_dir), gear_stiffness))
    p.start()
    b.close()
    try:
        res = a.recv()
    except EOFError:
        res = {"ok": False, "error": "calibration process died (killed, out of memory?)"}
    p.join()
    if p.exitcode not in (0, None) and res.get("ok"):
        res = {"ok": False, "error": f"exit code {p.exitcode}"}
    return res


def _param_errors(kind: str, named: dict[str, Any], truth: dict[str, float]) -> dict[str, float]:
    out = {}
    for name in KEY_PARAMS.get(kind, {}):
        if name in truth and name in named:
            out[name] = abs(float(named[name]) - truth[name]) / abs(truth[name])
    return out


def score(records: list[dict[str, Any]], out_of_library: tuple[str, ...] = OUT_OF_LIBRARY) -> dict[str, Any]:
    """Aggregate per-record outcomes into the benchmark figures (see the module docstring).
    ``out_of_library``: the generator's names of effects outside the library."""
    ool_names = tuple(out_of_library)
    rows = list(LIBRARY_KINDS) + ["clean"] + list(ool_names)
    cols = list(LIBRARY_KINDS) + ["none"]
    conf = {r: {c: 0 for c in cols} for r in rows}
    n_exact = 0
    clean_fp = []
    ool_ok = []
    ool_unexplained = 0
    n_clean = n_ool = 0
    missed_undecided: list[int] = []   # records whose only misses are reported undecided
    per_kind = {k: {"named": 0, "named_and_hidden": 0, "hidden": 0, "hidden_and_named": 0, "wrongly_named_seeds": []}
                for k in LIBRARY_KINDS}
    errors: dict[str, dict[str, list[float]]] = {k: {p: [] for p in v} for k, v in KEY_PARAMS.items()}
    for r in records:
        named = set(r["named"])
        hidden_lib = {h for h in r["hidden"] if h in LIBRARY_KINDS}
        hidden_rows = list(r["hidden"]) or ["clean"]
        for h in hidden_rows:
            for n in (sorted(named) or ["none"]):
                conf[h][n] += 1
        r["exact"] = named == hidden_lib
        n_exact += r["exact"]
        for k in named & set(per_kind):
            per_kind[k]["named"] += 1
            per_kind[k]["named_and_hidden"] += k in hidden_lib
            if k not in hidden_lib:
                per_kind[k]["wrongly_named_seeds"].append(r["seed"])
        for k in hidden_lib:
            per_kind[k]["hidden"] += 1
            per_kind[k]["hidden_and_named"] += k in named
        missed = hidden_lib - named
        if missed and not named - hidden_lib and missed <= {u["kind"] for u in r.get("undecided", [])}:
            missed_undecided.append(r["seed"])
        if not r["hidden"]:
            n_clean += 1
            if named:
                clean_fp.append(r["seed"])
        if any(h in ool_names for h in r["hidden"]):
            n_ool += 1
            ok = not named
            ool_ok.append(ok)
            ool_unexplained += bool(r["unexplained"])
        for k, errs in r.get("param_errors", {}).items():
            for p, e in errs.items():
                errors[k][p].append(e)
    n = len(records)
    limits = None
    if records and all("motion" in r for r in records):
        classes: dict[str, list[int]] = {}
        for r in records:
            r["miss_class"] = miss_class(r)
            if r["miss_class"]:
                classes.setdefault(r["miss_class"], []).append(r["seed"])
        n_ab = sum(len(v) for k, v in classes.items() if set(k) & set("AB"))
        n_abc = sum(len(v) for k, v in classes.items() if set(k) & set("ABC"))
        limits = {"classes": {k: {"n": len(v), "seeds": v} for k, v in sorted(classes.items())},
                  "nameable": n - n_ab, "nameable_at_rule_level": n - n_abc, "min_reversals": MIN_REVERSALS}
    key = {}
    for k, ps in errors.items():
        for p, es in ps.items():
            tol = KEY_PARAMS[k][p]
            key[f"{k}.{p}"] = {
                "n": len(es), "median_rel_err": float(np.median(es)) if es else None,
                "max_rel_err": float(np.max(es)) if es else None, "tolerance": tol,
                "within_tolerance": (int(sum(e <= tol for e in es)) if tol is not None else None),
            }
    walls = [r["wall_s"] for r in records if r.get("wall_s") is not None]
    peaks = [r["peak_rss_mb"] for r in records if r.get("peak_rss_mb") is not None]
    per_sample_s = [r["wall_s"] / r["n_samples"] for r in records if r.get("wall_s") is not None]
    cpus = [r["cpu_s"] for r in records if r.get("cpu_s") is not None]
    return {
        "n_records": n,
        "exact_set_accuracy": n_exact / n if n else None,
        "n_exact": n_exact,
        "clean": {"n": n_clean, "false_positive_seeds": clean_fp},
        # wrong only by effects the record has too few reversals to decide, and that the report says so
        "missed_reported_undecided": {"n": len(missed_undecided), "seeds": missed_undecided},
        # what the records allow, from their true motion (None when the records do not carry it)
        "limits": limits,
        "out_of_library": {"n": n_ool, "ok": int(sum(ool_ok)), "ok_fraction": (sum(ool_ok) / n_ool) if n_ool else None,
                           "with_unexplained_entry": ool_unexplained},
        "confusion": {"rows": rows, "cols": cols, "counts": conf},
        # when a report names the kind, how often the record hides it; when a record hides it, how often it is named
        "per_kind": {k: {**v, "named_right_fraction": (v["named_and_hidden"] / v["named"]) if v["named"] else None,
                         "found_fraction": (v["hidden_and_named"] / v["hidden"]) if v["hidden"] else None}
                     for k, v in per_kind.items()},
        "key_parameters": key,
        "time": {"median_s": float(np.median(walls)) if walls else None, "max_s": max(walls) if walls else None,
                 "median_us_per_sample": 1e6 * float(np.median(per_sample_s)) if per_sample_s else None,
                 "median_cpu_s": float(np.median(cpus)) if cpus else None},
        "memory": {"median_peak_rss_mb": float(np.median(peaks)) if peaks else None,
                   "max_peak_rss_mb": max(peaks) if peaks else None},
        "failures": [r["seed"] for r in records if not r.get("ok", True)],
    }


def run_benchmark(out_dir: str | Path, seeds: tuple[int, ...] | list[int] = DEFAULT_SEEDS, long_samples: int | None = None,
                  progress=print, generator_name: str = "independent") -> dict[str, Any]:
    """Generate, calibrate and score; write ``benchmark.json`` and ``benchmark.md`` into ``out_dir``.

    Parameters
    ----------
    out_dir : path
    seeds : sequence of int
        One record per seed (the generator's ``make_record``).
    long_samples : int, optional
        Also calibrate one long record of this many samples (memory/time of hour-long logs; always
        from the ``independent`` generator, which can repeat a trajectory to any length).
    progress : callable
        Called with one line per record.
    generator_name : str
        Which record generator (:data:`GENERATORS`): ``independent`` (default) or ``blind``.

    Returns
    -------
    dict
        The content of ``benchmark.json``.

    Raises
    ------
    ValueError
        An unknown generator, or its kind list differs from the ``plant.effects`` registry.
    """
    gen = generator(generator_name)
    out = Path(out_dir)
    (out / "records").mkdir(parents=True, exist_ok=True)
    records = []
    for seed in seeds:
        rec = gen.make_record(int(seed))
        csv_path = out / "records" / f"seed_{seed:03d}.csv"
        rec.write_csv(csv_path)
        # a two-mass drive's stiffness, as the engineer would give it from the drive's design
        stiffness = rec.meta.get("two_mass", {}).get("stiffness_nm_rad")
        res = _calibrate_isolated(csv_path, out / "runs" / f"seed_{seed:03d}", stiffness)
        entry: dict[str, Any] = {"seed": int(seed), "hidden": list(rec.hidden), "truth": rec.truth,
                                 "n_samples": int(rec.t_s.size), "fs_hz": rec.meta["fs_log_hz"],
                                 "trajectory": rec.meta["trajectory"], "ok": res["ok"], "motion": record_motion(rec)}
        if res["ok"]:
            entry["named"] = [e["kind"] for e in res["effects"]]
            entry["effects"] = res["effects"]
            entry["unexplained"] = res["unexplained"]
            entry["undecided"] = [{k: u[k] for k in ("kind", "reason", "cv_gain_pct", "n_reversals", "min_reversals") if k in u}
                                  for u in res["undecided"]]
            entry["conclusion"] = res["conclusion"]
            entry["wall_s"] = res["wall_s"]
            entry["cpu_s"] = res["cpu_s"]
            entry["peak_rss_mb"] = res["peak_rss_mb"]
            entry["param_errors"] = {}
            for e in res["effects"]:
                if e["kind"] in rec.truth:
                    named, truth = e["params"], rec.truth[e["kind"]]
                    if e["kind"] == "backlash" and "gap_rad" in e:
                        named, truth = {**named, "gap_rad": e["gap_rad"]}, {**truth, "gap_rad": truth["width_rad"]}
                    entry["param_errors"][e["kind"]] = _param_errors(e["kind"], named, truth)
        else:
            entry["named"] = []
            entry["unexplained"] = []
            entry["undecided"] = []
            entry["error"] = res["error"]
        records.append(entry)
        progress(f"seed {seed:3d} hidden {','.join(rec.hidden) or 'clean':40s} named {','.join(entry['named']) or '-':40s} "
                 f"{'OK ' if set(entry['named']) == {h for h in rec.hidden if h in LIBRARY_KINDS} else 'BAD'} "
                 f"{entry.get('wall_s', float('nan')):.1f} s {entry.get('error', '')}")
    summary = score(records, tuple(gen.OUT_OF_LIBRARY))
    result: dict[str, Any] = {"generator": generator_name, "generator_module": GENERATORS[generator_name],
                              "seeds": [int(s) for s in seeds], "targets": TARGETS, "summary": summary, "records": records}
    if long_samples:
        rec = make_record(int(seeds[0]) if seeds else 0, n_samples=int(long_samples))
        csv_path = out / "records" / f"long_{long_samples}.csv"
        rec.write_csv(csv_path)
        res = _calibrate_isolated(csv_path, out / "runs" / "long")
        n = int(rec.t_s.size)
        lr = {"n_samples": n, "hidden": list(rec.hidden), "fs_hz": rec.meta["fs_log_hz"], "ok": res["ok"]}
        if res["ok"]:
            lr.update({"wall_s": res["wall_s"], "cpu_s": res["cpu_s"], "peak_rss_mb": res["peak_rss_mb"], "us_per_sample": 1e6 * res["wall_s"] / n,
                       "peak_bytes_per_sample": res["peak_rss_mb"] * 2**20 / n, "named": [e["kind"] for e in res["effects"]]})
        else:
            lr["error"] = res["error"]
        result["long_record"] = lr
        progress(f"long record: {lr}")
    (out / "benchmark.json").write_text(json.dumps(_clean(result), indent=2))
    (out / "benchmark.md").write_text(markdown(result))
    return result


def _clean(x):
    if isinstance(x, dict):
        return {str(k): _clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    if isinstance(x, (np.floating, np.integer)):
        x = x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def _pct(x) -> str:
    return "—" if x is None else f"{100 * x:.1f} %"


def per_kind_table(summary: dict[str, Any]) -> list[str]:
    """The markdown lines of :func:`score`'s ``per_kind`` (kinds neither named nor hidden left out)."""
    L = ["| kind | named | of which hidden | hidden | of which named | named where not hidden (seeds) |",
         "|---|---|---|---|---|---|"]
    for k, v in summary["per_kind"].items():
        if v["named"] or v["hidden"]:
            L.append(f"| {k} | {v['named']} | {v['named_and_hidden']} ({_pct(v['named_right_fraction'])}) | {v['hidden']} | "
                     f"{v['hidden_and_named']} ({_pct(v['found_fraction'])}) | "
                     f"{', '.join(map(str, v['wrongly_named_seeds'])) or '—'} |")
    return L


def markdown(result: dict[str, Any]) -> str:
    """``benchmark.md``: the summary, the confusion matrix and the per-record table."""
    s = result["summary"]
    L = [f"# Calibration benchmark (generator `{result.get('generator', 'independent')}`: "
         f"`{result.get('generator_module', GENERATORS['independent'])}`)", "",
         f"Seeds: {result['seeds'][0]}…{result['seeds'][-1]} ({s['n_records']} records).", "",
         f"- exact set of effects named right: **{s['n_exact']}/{s['n_records']} = {_pct(s['exact_set_accuracy'])}** (target ≥ 90 %)",
         f"- clean records with an invented effect: **{len(s['clean']['false_positive_seeds'])}/{s['clean']['n']}** "
         f"(target 0){' — seeds ' + str(s['clean']['false_positive_seeds']) if s['clean']['false_positive_seeds'] else ''}",
         f"- out-of-library records with no library kind named: **{s['out_of_library']['ok']}/{s['out_of_library']['n']} = "
         f"{_pct(s['out_of_library']['ok_fraction'])}** (target ≥ 90 %); with an `unexplained` entry: "
         f"{s['out_of_library']['with_unexplained_entry']}",
         f"- time per record: median {s['time']['median_s']:.1f} s, max {s['time']['max_s']:.1f} s; "
         f"{s['time']['median_us_per_sample']:.0f} µs per sample (median)" if s["time"]["median_s"] is not None else "- time: —",
         f"- peak RSS per calibration (child process): median {s['memory']['median_peak_rss_mb']:.0f} MB, "
         f"max {s['memory']['max_peak_rss_mb']:.0f} MB" if s["memory"]["median_peak_rss_mb"] is not None else "- memory: —",
         ]
    mu = s.get("missed_reported_undecided", {"n": 0, "seeds": []})
    L.append(f"- records wrong only by effects the report lists as not decided by the record (too few reversals, or a "
             f"periodic motion): "
             f"{mu['n']}/{s['n_records'] - s['n_exact']} of the wrong ones" + (f" — seeds {mu['seeds']}" if mu["seeds"] else ""))
    lim = s.get("limits")
    if lim:
        L.append(f"- what the records allow (from their true motion, not the loop): exact sets nameable at all "
                 f"**{lim['nameable']}/{s['n_records']}**, at the rank test's level (≥ {lim['min_reversals']} reversals for a "
                 f"reversal kind) **{lim['nameable_at_rule_level']}/{s['n_records']}**; the wrong ones by class: "
                 + ("; ".join(f"{k} {v['n']} {v['seeds']}" for k, v in lim["classes"].items()) or "none")
                 + " (" + "; ".join(f"{k}: {d}" for k, d in MISS_CLASSES.items()) + ")")
    if s["failures"]:
        L.append(f"- runs that failed: seeds {s['failures']}")
    if "long_record" in result:
        lr = result["long_record"]
        if lr.get("ok"):
            L.append(f"- long record: {lr['n_samples']} samples at {lr['fs_hz']:g} Hz: {lr['wall_s']:.0f} s wall "
                     f"({lr['cpu_s']:.0f} s CPU), "
                     f"peak RSS {lr['peak_rss_mb']:.0f} MB ({lr['us_per_sample']:.1f} µs and {lr['peak_bytes_per_sample']:.0f} B per sample)")
        else:
            L.append(f"- long record: failed ({lr.get('error')})")
    L += ["", "## Confusion matrix (hidden × named)", ""]
    c = s["confusion"]
    L.append("| hidden \\ named | " + " | ".join(c["cols"]) + " |")
    L.append("|---" * (len(c["cols"]) + 1) + "|")
    for r in c["rows"]:
        if sum(c["counts"][r].values()):
            L.append(f"| {r} | " + " | ".join(str(c["counts"][r][k] or "") for k in c["cols"]) + " |")
    if "per_kind" in s:
        L += ["", "## Per kind: when a report names it, and when a record hides it", ""] + per_kind_table(s)
    L += ["", "## Key parameters (correctly named kinds)", "", "| parameter | n | median error | max error | tolerance | within |",
          "|---|---|---|---|---|---|"]
    for k, v in s["key_parameters"].items():
        if v["n"]:
            tol = "—" if v["tolerance"] is None else f"{100 * v['tolerance']:g} %"
            L.append(f"| {k} | {v['n']} | {_pct(v['median_rel_err'])} | {_pct(v['max_rel_err'])} | {tol} | "
                     f"{'—' if v['within_tolerance'] is None else v['within_tolerance']} |")
    L += ["", "## Records", "", "| seed | hidden | named | exact | unexplained | undecided: gain (reversals / needed, or periodic) | "
          "fs [Hz] | samples | "
          "trajectory | time [s] | peak RSS [MB] |",
          "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in result["records"]:
        un = "; ".join(f"{u['domain']} {u['share_pct']:.0f} %" for u in r.get("unexplained", []))
        ud = "; ".join(f"{u['kind']} {u['cv_gain_pct']:.2g} % "
                       + (f"({u['n_reversals']}/{u['min_reversals']})" if "n_reversals" in u else "(periodic)")
                       for u in r.get("undecided", []))
        L.append(f"| {r['seed']} | {', '.join(r['hidden']) or 'clean'} | {', '.join(r['named']) or '—'} | "
                 f"{'yes' if r.get('exact') else 'no'} | {un} | {ud} | {r['fs_hz']:g} | {r['n_samples']} | {r['trajectory']} | "
                 f"{r.get('wall_s', float('nan')):.1f} | {r.get('peak_rss_mb', float('nan')):.0f} |")
    return "\n".join(L) + "\n"


def default_seeds() -> tuple[int, ...]:
    """The fixed seed list of the full benchmark."""
    return DEFAULT_SEEDS


def ci_seeds() -> tuple[int, ...]:
    """The fixed subset CI runs."""
    return CI_SEEDS
