"""Regenerate the validation against the paper: run every scenario the table needs, compare like with like.

``schmidt-fil validate-paper --out DIR`` writes ``DIR/validation.json`` (``rows``: ``figure``,
``paper``, ``emulator``, ``metric``, ``agrees``, ``cause``, plus ``role``, ``scenario``,
``segment``, ``peak_current_a``) and ``DIR/validation.md``; ``docs/validation.md`` is that file.
Each run's own ``report.json``/``report.md`` goes to ``DIR/runs/<name>/``.

Rules (fixed before any comparison was made; see issue 9):

* **Like with like.** Every paper figure of §4 is compared with ``peak_error_tick_pct``: the
  firmware's own 5 ms QEI-difference rate, which is what the controller and (most likely) the
  paper's plots show (:mod:`host.rate_metrics`). The 10 ms and 100 ms figures are listed beside it.
* **Agreement criteria**, with *r* = one QEI count per tick in % of the setpoint (the reading's
  resolution):

  - a range "a–b %": a − r ≤ x ≤ b + r;
  - a bound "< b %" or "up to b %": x ≤ b + r;
  - "≈ X %": |x − X| ≤ max(0.2 X, r/2) (at 15″/s r/2 = 7.7 %: the same reading once quantised);
  - qualitative rows state their test in the row (``metric``).
* **Identification is not prediction.** The one number identified on a figure (the RA stage-1
  mesh amplitude, on Fig. 6a, :mod:`host.identify_mesh`) makes that figure's rows ``role:
  identification`` or ``same figure as identification``; they are shown but never counted.
* **Causes are measured.** A row that does not agree names its cause with numbers from runs made
  here (a sensitivity run changes one assumed parameter and is labelled as such; nothing is adopted
  from it).

``duration_scale`` (tests, CI) shortens every segment; the table is then a structure check only.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

__all__ = ["RUNS", "validate_paper", "write_validation", "ROW_FIELDS"]

_ROOT = Path(__file__).resolve().parent.parent
SCEN = _ROOT / "scenarios"

#: Runs the table needs: name -> (scenario file, plant overrides, why).
RUNS = {
    "fig6a": (SCEN / "paper" / "fig6a-open-loop-600.yaml", {}, "Fig. 6a identification run"),
    "open-loop": (SCEN / "open-loop.yaml", {}, "open loop 1000/600/100/50/15″/s"),
    "fig7a": (SCEN / "paper" / "fig7a-open-loop-100.yaml", {}, "Fig. 7a open loop 100″/s, 60 s measured"),
    "high-speed": (SCEN / "high-speed.yaml", {}, "closed loop 600, 1000″/s, 1 and 3°/s"),
    "high-speed-no-mesh": (SCEN / "high-speed.yaml", {"axes.ra.gear_disturbance.stage1_mesh.amplitude_nm": 0.0},
                           "sensitivity: without the identified mesh line"),
    "fig7b": (SCEN / "paper" / "fig7b-closed-loop-100.yaml", {}, "Fig. 7b closed loop 100″/s"),
    "fig7b-delta1": (SCEN / "paper" / "fig7b-closed-loop-100.yaml", {"axes.ra.friction.delta": 1.0},
                     "sensitivity: Stribeck exponent δ = 1 instead of the assumed 2"),
    "fig7b-no-stribeck": (SCEN / "paper" / "fig7b-closed-loop-100.yaml", {"axes.ra.friction.low.ts_nm": 229.0},
                          "sensitivity: no Stribeck drop (Ts = Tc = 229 N·m, Table 2 low preload)"),
    "fig7b-half-gains": (SCEN / "paper" / "fig7b-closed-loop-100.yaml", {"controller_gain_scale": 0.5},
                         "sensitivity: the tuning rule's Kp and Ki halved"),
    "tracking-low": (SCEN / "tracking-low-preload.yaml", {}, "Fig. 13b tracking, reduced preload"),
    "tracking-high": (SCEN / "tracking-high-preload.yaml", {}, "Fig. 13a tracking, high preload"),
    "tracking-high-sigma0-1e9": (SCEN / "tracking-high-preload.yaml", {"axes.ra.friction.sigma0_nm_rad": 1.0e9},
                                 "sensitivity: σ0 = 1e9 instead of the assumed 1e8"),
    "tracking-low-sigma0-1e9": (SCEN / "tracking-low-preload.yaml", {"axes.ra.friction.sigma0_nm_rad": 1.0e9},
                                "sensitivity: σ0 = 1e9 at reduced preload"),
}

ROW_FIELDS = ("figure", "paper", "emulator", "metric", "agrees", "cause", "role", "scenario", "segment",
              "peak_current_a")


def _scaled(sc, scale: float, overrides: dict):
    pc = sc.plant
    upd = {"plant": pc.model_copy(update={"overrides": {**pc.overrides, **overrides}})}
    if scale != 1.0:
        segs = []
        for s in sc.segments:
            d = max(1.0, s.duration_s * scale)
            st = min(s.settle_s * scale, 0.5 * d) if s.mode != "stop" else 0.0
            segs.append(s.model_copy(update={"duration_s": d, "settle_s": st}))
        upd["segments"] = segs
    return sc.model_copy(update=upd)


def run_all(out_dir: Path, duration_scale: float = 1.0, progress=None) -> dict:
    """Run every scenario of :data:`RUNS`; returns ``{name: report dict}``."""
    from host.runner import run_scenario
    from host.scenario import load_scenario

    reports = {}
    for name, (path, overrides, _why) in RUNS.items():
        overrides = dict(overrides)
        gain_scale = overrides.pop("controller_gain_scale", None)
        sc = _scaled(load_scenario(path), duration_scale, overrides)
        if gain_scale is not None:  # the tuning rule's gains as the base run used them, scaled
            base = reports["fig7b"]["controller"]["ra"]
            cc = sc.controller.ra.model_copy(update={"kp": base["kp_duty_per_arcsec_s"] * gain_scale,
                                                     "ki": base["ki_duty_per_arcsec_s_tick"] * gain_scale})
            sc = sc.model_copy(update={"controller": sc.controller.model_copy(update={"ra": cc})})
        d = out_dir / "runs" / name
        d.mkdir(parents=True, exist_ok=True)
        res = run_scenario(sc, d, plots=False)
        reports[name] = res.report
        if progress:
            progress(name)
    return reports


def _seg(reports: dict, run: str, name: str) -> dict:
    for s in reports[run]["segments"]:
        if s["name"] == name:
            return s
    raise KeyError(f"run {run}: no segment {name}")


def _f(x, nd=2):
    return "–" if x is None else f"{x:.{nd}f}"


@dataclass
class _Row:
    figure: str
    paper: str
    metric: str
    role: str = "prediction"

    def make(self, emulator: str, agrees, cause: str, run: str, seg: str, current) -> dict:
        return {"figure": self.figure, "paper": self.paper, "emulator": emulator, "metric": self.metric,
                "agrees": agrees, "cause": cause, "role": self.role, "scenario": run, "segment": seg,
                "peak_current_a": current}


def _in_range(x, lo, hi, r):
    return x is not None and lo - r <= x <= hi + r


def _lines_text(s: dict) -> str:
    ls = s.get("disturbance_lines") or []
    if not ls:
        return "no spectral line ≥ 0.5 %"
    return ", ".join(f"{ln['frequency_hz']:.3g} Hz {ln['amplitude_pct']:.2f} % ("
                     + (ln["gear_line"]["line"] if ln.get("gear_line") else "no gear order") + ")" for ln in ls)


def build_rows(reports: dict) -> list[dict]:
    """The validation table from the run reports (see the module docstring for the criteria)."""
    rows = []
    # ---------------------------------------------------------------- Fig. 6a (identification)
    s = _seg(reports, "fig6a", "ol600")
    x, r = s["peak_error_tick_pct"], s["tick_resolution_pct"]
    rows.append(_Row("Fig. 6a (§4)", "open loop 600″/s, reduced preload: peak error up to 15 %",
                     "peak_error_tick_pct", "identification").make(
        f"{_f(x)} % per tick (10 ms {_f(s['peak_error_10ms_pct'])} %, 100 ms {_f(s['peak_error_pct'])} %); {_lines_text(s)}",
        None, "not a prediction: the RA stage-1 mesh amplitude was identified on this figure "
              "(`schmidt-fil identify-mesh`)", "fig6a", "ol600", s["peak_current_a"]))
    s = _seg(reports, "open-loop", "ol1000")
    x, r = s["peak_error_tick_pct"], s["tick_resolution_pct"]
    rows.append(_Row("Fig. 6a (§4)", "open loop at high speed (1000″/s): peak error up to 15 %",
                     "peak_error_tick_pct ≤ 15 + r", "same figure as identification").make(
        f"{_f(x)} % per tick; {_lines_text(s)}", None,
        f"not counted (same figure as the identification); within the bound: {_in_range(x, 0, 15, r)}",
        "open-loop", "ol1000", s["peak_current_a"]))
    # ---------------------------------------------------------------- closed loop, high speed
    nomesh = {}
    for seg in ("v600", "v1000", "v1deg", "v3deg", "v3deg-reverse"):
        nomesh[seg] = _seg(reports, "high-speed-no-mesh", seg)["peak_error_tick_pct"]
    for seg, fig, rate in (("v600", "Figs. 6b, 12 (§4)", 600), ("v1000", "Fig. 12 (§4)", 1000)):
        s = _seg(reports, "high-speed", seg)
        x, r = s["peak_error_tick_pct"], s["tick_resolution_pct"]
        ok = _in_range(x, 2.0, 7.0, r)
        osc = (f"forced line {s['forced_line']['gear_line']['line']} at {s['forced_line']['frequency_hz']:.3g} Hz"
               if s.get("forced_line") else ("limit cycle" if s.get("limit_cycle") else "no limit cycle"))
        cause = (f"the identified stage-1 mesh line ({_lines_text(s)}); {osc}. Without it: "
                 f"{_f(nomesh[seg])} % (`high-speed-no-mesh`)")
        rows.append(_Row(fig, f"closed loop {rate}″/s, reduced preload: peak error 2–7 %",
                         "peak_error_tick_pct in [2 − r, 7 + r]").make(
            f"{_f(x)} % per tick (rms {_f(s['rms_error_tick_pct'])} %; 10 ms {_f(s['peak_error_10ms_pct'])} %; "
            f"100 ms {_f(s['peak_error_pct'])} %)", ok, cause if ok else "disagrees: " + cause,
            "high-speed", seg, s["peak_current_a"]))
    for segs, rate in ((("v1deg",), "1°/s"), (("v3deg", "v3deg-reverse"), "3°/s (both directions)")):
        ss = [_seg(reports, "high-speed", g) for g in segs]
        x = max(s["peak_error_tick_pct"] for s in ss)
        r = ss[0]["tick_resolution_pct"]
        ok = x <= 1.0 + r
        mean = ", ".join(f"{s['mean_rate_arcsec_s']:g}″/s" for s in ss)
        cur = max(s["peak_current_a"] for s in ss)
        over = max(s["time_over_rating_s"] for s in ss)
        nm = max(nomesh[g] for g in segs)
        cause = (f"holds the rate (mean {mean}); without the mesh line {_f(nm)} %. "
                 f"Peak current {cur:.2f} A, {over:.1f} s over the 6 A rating"
                 + (" (the paper's motors are rated 6 A continuous: with the assumed K, R this speed needs more)"
                    if over > 0 else ""))
        if not ok:
            cause = f"disagrees: mean {mean}, {cur:.2f} A; " + ("the axis saturates" if any(
                abs(s["mean_error_pct"]) > 1 for s in ss) else "error above the bound")
        rows.append(_Row("§4 (ref. 18)", f"closed loop {rate}: peak errors within 1 %", "peak_error_tick_pct ≤ 1 + r").make(
            f"{_f(x)} % per tick", ok, cause, "high-speed", "/".join(segs), cur))
    # ---------------------------------------------------------------- tracking
    lo = _seg(reports, "tracking-low", "track")
    x, r = lo["peak_error_tick_pct"], lo["tick_resolution_pct"]
    ok = x is not None and abs(x - 25.0) <= max(0.2 * 25.0, r / 2)
    rows.append(_Row("Fig. 13b (§4, §6)", "tracking 15″/s, reduced preload: peak error ≈ 25 %",
                     "|peak_error_tick_pct − 25| ≤ max(5, r/2)").make(
        f"{_f(x)} % per tick (one count = {_f(r)} %; 10 ms {_f(lo['peak_error_10ms_pct'])} %, 100 ms "
        f"{_f(lo['peak_error_pct'])} %); {'limit cycle' if lo['limit_cycle'] else 'no limit cycle'}",
        ok, (f"per-tick readings of 6.53 counts are 6 or 7 counts, the worst one count further (±22–24 %); "
             f"peak current {lo['peak_current_a']:.2f} A, {lo['time_over_rating_s']:.1f} s over 6 A")
        if ok else "disagrees", "tracking-low", "track", lo["peak_current_a"]))
    hi = _seg(reports, "tracking-high", "track")
    s9 = _seg(reports, "tracking-high-sigma0-1e9", "track")
    l9 = _seg(reports, "tracking-low-sigma0-1e9", "track")
    xh = hi["peak_error_tick_pct"]
    ok = bool(hi["limit_cycle"]) and xh is not None and x is not None and xh >= 2.0 * x
    rows.append(_Row("Fig. 13a (§4)", "tracking 15″/s, high preload: limit cycles, much larger peak errors than 13b",
                     "limit_cycle and peak_error_tick_pct ≥ 2 × Fig. 13b's").make(
        f"{_f(xh)} % per tick, {'limit cycle' if hi['limit_cycle'] else 'no limit cycle'}, "
        f"{hi['stuck_fraction'] * 100:.0f} % of samples stuck; {hi['peak_current_a']:.2f} A "
        f"({hi['time_over_rating_s']:.1f} s over 6 A)", ok,
        ("" if ok else "disagrees: ") + f"depends on the assumed σ0: with σ0 = 1e9 (sensitivity run) "
        f"{_f(s9['peak_error_tick_pct'])} % per tick, {'limit cycle' if s9['limit_cycle'] else 'no limit cycle'}"
        + (f" ({s9['limit_cycle_period_s']} s)" if s9.get("limit_cycle_period_s") else "")
        + f", {s9['stuck_fraction'] * 100:.0f} % stuck — but the same σ0 at reduced preload gives "
        f"{_f(l9['peak_error_tick_pct'])} % per tick ({'limit cycle' if l9['limit_cycle'] else 'no limit cycle'}), "
        f"breaking Fig. 13b: no single σ0 gives both figures with this model, so the assumed 1e8 stays. Holding "
        f"15″/s at high preload needs {hi['peak_current_a']:.1f} A, over the 6 A rating with the assumed "
        f"K = 0.35 N·m/A", "tracking-high", "track", hi["peak_current_a"]))
    # ---------------------------------------------------------------- open loop, low speed
    ss = [_seg(reports, "open-loop", g) for g in ("ol50", "ol15")]
    held = [abs(s["mean_error_pct"]) <= 25.0 for s in ss]
    ok = not any(held)
    desc = "; ".join(f"{s['name']}: mean {s['mean_rate_arcsec_s']:g}″/s" for s in ss)
    rows.append(_Row("§4, §6", "open loop cannot hold speeds below 100″/s",
                     "|mean rate error| > 25 % at 50 and 15″/s").make(
        desc, ok, ("below ω_s the static friction curve falls with speed, so the duty that balances friction at "
                   "the target exceeds the friction on the viscous branch: no stable open-loop operating point; "
                   "the axis " + " and ".join(("runs away" if s["mean_rate_arcsec_s"] > s["setpoint_arcsec_s"] else "stops")
                                              + f" at {s['name']}" for s in ss))
        if ok else "disagrees: an open-loop speed below 100″/s was held",
        "open-loop", "ol50/ol15", max(s["peak_current_a"] for s in ss)))
    s = _seg(reports, "fig7a", "ol100")
    held = abs(s["mean_error_pct"]) <= 25.0
    slow = [ln for ln in s.get("disturbance_lines") or [] if 0.03 <= ln["frequency_hz"] <= 0.08]
    ok = held and bool(slow)
    rows.append(_Row("Fig. 7a (§4)", "open loop 100″/s: high errors, oscillation close to 0.05 Hz",
                     "mean within 25 % of 100″/s and a spectral line in 0.03–0.08 Hz").make(
        f"mean {s['mean_rate_arcsec_s']:g}″/s, {_f(s['peak_error_tick_pct'])} % per tick; {_lines_text(s)}", ok,
        ("" if ok else "disagrees: ") + (
            f"the open-loop duty for 100″/s sits on the falling Stribeck curve (ω_s ≈ 83″/s): the axis "
            f"{'runs away' if s['mean_rate_arcsec_s'] > 125 else ('stops' if s['mean_rate_arcsec_s'] < 75 else 'holds')} "
            f"(mean {s['mean_rate_arcsec_s']:g}″/s). The 0.05 Hz line matches twice per motor revolution "
            f"(0.056 Hz at 100″/s), whose amplitude is unsourced (0 in the parameter file)"),
        "fig7a", "ol100", s["peak_current_a"]))
    s = _seg(reports, "fig7b", "v100")
    ol = _seg(reports, "fig7a", "ol100")
    sens = [(k, _seg(reports, k, "v100")) for k in ("fig7b-delta1", "fig7b-no-stribeck", "fig7b-half-gains")]
    ok = (not s["limit_cycle"]) and abs(s["mean_error_pct"]) < 5.0 and s["peak_error_tick_pct"] < ol["peak_error_tick_pct"]

    def osc(x):
        return (f"limit cycle {x['limit_cycle_period_s']} s" if x["limit_cycle"] else "no limit cycle")

    ns = dict(sens)["fig7b-no-stribeck"]
    verdict = (" Measured cause: the Stribeck drop (Ts − Tc of Table 2) — removing it alone ends the hunting."
               if s["limit_cycle"] and not ns["limit_cycle"] else "")
    sens_txt = "; ".join(f"{RUNS[k][2].split(': ', 1)[1]}: {_f(x['peak_error_tick_pct'])} % per tick, {osc(x)}"
                         for k, x in sens)
    rows.append(_Row("Fig. 7b (§4)", "closed loop 100″/s: the controller reduces the error band vs open loop (Fig. 7a)",
                     "no limit cycle, |mean error| < 5 %, peak_error_tick_pct below Fig. 7a's run").make(
        f"{_f(s['peak_error_tick_pct'])} % per tick, {osc(s)}, mean {s['mean_rate_arcsec_s']:g}″/s "
        f"(open loop: {_f(ol['peak_error_tick_pct'])} %)", ok,
        ("" if ok else "disagrees: ") + f"100″/s sits at Table 2's Stribeck velocity (ω_s = 4e-4 rad/s ≈ 83″/s). "
        f"Sensitivity runs (one assumption changed each): {sens_txt}.{verdict} The paper's own Simulink model "
        "showed oscillations at low speed too (§4)",
        "fig7b", "v100", s["peak_current_a"]))
    return rows


def _markdown(rows: list[dict], reports: dict, params, scale: float) -> str:
    counted = [r for r in rows if r["role"] == "prediction"]
    n_ok = sum(1 for r in counted if r["agrees"])
    # what ran (the Fig. 6a run's plant), not the file read again; the source text from the resolved file
    ran = [ln for ln in reports["high-speed"].get("gear_lines", {}).get("ra", []) if ln["line"] == "stage1_mesh"]
    mesh_nm = ran[0]["amplitude_nm"] if ran else 0.0
    cf = reports["high-speed"]["controller"]["ra"]["counter_fraction"]
    src = params.tree["axes"]["ra"]["gear_disturbance"]["stage1_mesh"]["amplitude_nm"]["source"]
    L = ["# Validation against the paper", "",
         "Generated by `schmidt-fil validate-paper --out DIR` (host/validate_paper.py); this page is that "
         "command's `validation.md`. Do not edit by hand: rerun it.", ""]
    if scale != 1.0:
        L += [f"**Shortened run (duration scale {scale:g}): a structure check, not a validation.**", ""]
    L += [f"**{n_ok} of {len(counted)} predicted rows agree** on like-for-like metrics; each other row names its "
          f"measured cause. Rows marked *identification* or *same figure as identification* are shown, not counted.", "",
          "## What fixed which number", "",
          f"- RA stage-1 gear-mesh torque amplitude **{mesh_nm:g} N·m per train** at the axis: "
          f"Fig. 6a alone. Source in the parameter file: {src}",
          f"- Counter-motor ratio **p = {cf:g}**: Table 1 (starting torque = load + counter "
          "torque, 233/1166 = 79/395 = 0.20); not fitted to any figure.",
          "- Everything else: the paper's tables (Tables 1, 2), or `assumed:` values in `plant/parameters.yaml` "
          "chosen before any comparison (R, L, K, σ0, σ1, δ). Every other gear line's amplitude is 0 (unsourced).",
          "", "## How the comparison is made", "",
          "Errors are `peak_error_tick_pct`: the axis firmware's own rate, the QEI difference over one 5 ms tick, "
          "as the host receives it in every `AXIS_AUX` frame (and the §3.4 telemetry carries it). *r* is one count "
          "per tick in % of the setpoint (15.3 % at 15″/s, 0.38 % at 600″/s). A range a–b agrees if "
          "a − r ≤ x ≤ b + r; a bound if x ≤ b + r; \"≈ X\" if |x − X| ≤ max(0.2 X, r/2). The 10 ms and 100 ms "
          "figures are given beside it. Criteria were fixed before running (host/validate_paper.py).", "",
          "## Table", "",
          "| figure | paper | emulator | metric | agrees | cause |", "|---|---|---|---|---|---|"]
    def cell(x):  # a "|" inside a cell would split the table
        return str(x).replace("|", "\\|")

    for r in rows:
        ag = {True: "**yes**", False: "**no**", None: f"– ({r['role']})"}[r["agrees"]]
        L.append(f"| {cell(r['figure'])} | {cell(r['paper'])} | {cell(r['emulator'])} (`{r['scenario']}: {r['segment']}`) | "
                 f"`{cell(r['metric'])}` | {ag} | {cell(r['cause'])} |")
    L += ["", "## Motor currents against the 6 A rating (§3.2)", "",
          "| run | segment | peak current (A) | s over 6 A |", "|---|---|---:|---:|"]
    for name, rep in reports.items():
        for s in rep["segments"]:
            if s.get("peak_current_a") is None:
                continue
            L.append(f"| {name} | {s['name']} | {s['peak_current_a']:.2f} | {s['time_over_rating_s']:.2f} |")
    L += ["", "## Runs", "", "| run | scenario | plant overrides | why |", "|---|---|---|---|"]
    for name, (path, ov, why) in RUNS.items():
        ovs = ", ".join(f"`{k} = {v:g}`" for k, v in ov.items()) or "–"
        L.append(f"| {name} | `{path.relative_to(_ROOT)}` | {ovs} | {why} |")
    L += ["", "Each run's `report.json`/`report.md` is in `DIR/runs/<run>/`; `schmidt-fil run SCENARIO` reproduces "
          "any of them (sensitivity runs: add the override under `plant.overrides`).", "",
          "## What is not validated", "",
          "- No measured data of this telescope exist in the project; every emulator number is a model prediction.",
          "- The absolute currents and the high-preload behaviour depend on the assumed motor constants (R, K) and "
          "σ0; a QT-3124 datasheet or measured friction would replace them.",
          "- Gear-line phases are assumed 0 (no data); only the RA stage-1 mesh amplitude is identified, DEC has no "
          "figure and keeps every amplitude 0.", ""]
    return "\n".join(L)


def write_validation(out_dir: Path, rows: list[dict], reports: dict, params, scale: float = 1.0) -> tuple[Path, Path]:
    """Write ``validation.json`` and ``validation.md`` into ``out_dir``; returns their paths."""
    out_dir.mkdir(parents=True, exist_ok=True)
    counted = [r for r in rows if r["role"] == "prediction"]
    doc = {"schema": "schmidt-fil/validation/1", "duration_scale": scale,
           "predictions": len(counted), "agree": sum(1 for r in counted if r["agrees"]),
           "rows": rows,
           "runs": {k: {"scenario": str(v[0].relative_to(_ROOT)), "overrides": v[1], "why": v[2]} for k, v in RUNS.items()}}
    jp = out_dir / "validation.json"
    jp.write_text(json.dumps(doc, indent=2, ensure_ascii=False) + "\n", encoding="utf-8")
    mp = out_dir / "validation.md"
    mp.write_text(_markdown(rows, reports, params, scale), encoding="utf-8")
    return jp, mp


def validate_paper(out_dir: Path, duration_scale: float = 1.0, progress=None) -> dict:
    """Run every scenario, build the table and write ``validation.json``/``validation.md``.

    Parameters
    ----------
    out_dir : Path
        Output directory (created).
    duration_scale : float
        Multiplies every segment's duration and settling (≤ 1; tests use a small value).
    progress : callable(run_name), optional

    Returns
    -------
    dict
        The ``validation.json`` document.

    Raises
    ------
    ValueError
        ``duration_scale`` outside (0, 1].
    """
    if not (0.0 < duration_scale <= 1.0) or math.isnan(duration_scale):
        raise ValueError(f"duration_scale must be in (0, 1], got {duration_scale}")
    out_dir = Path(out_dir)
    reports = run_all(out_dir, duration_scale, progress)
    rows = build_rows(reports)
    from host.scenario import load_scenario, resolve_parameters

    params = resolve_parameters(load_scenario(RUNS["high-speed"][0]))  # as the run resolved it (for sources)
    jp, _ = write_validation(out_dir, rows, reports, params, duration_scale)
    return json.loads(jp.read_text(encoding="utf-8"))
