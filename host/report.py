"""Tracking metrics, ``report.json``, ``report.md`` and the velocity / control-effort plots.

How velocity and errors are measured (this text is also written into every report):

* **Velocity** is what the operator sees: the incremental-encoder (QEI) count carried in every
  ``AXIS_STATUS`` frame (every 10 ms), unwrapped by the host, differenced over non-overlapping
  windows of ``velocity_window_ms`` (default 100 ms) and scaled by the axis controller's encoder
  resolution (``resolution_pct`` per segment; 0.01148 arcsec/count with the packaged parameters:
  4.608e6 counts/rev through the 1:24.5 roller, paper §2.2/§3.2). One count per 100 ms is then
  0.115 arcsec/s, 0.77 % of the 15 arcsec/s tracking rate: that is the resolution floor of the
  100 ms percentages. The per-tick (5 ms) rate has a 2.3 arcsec/s step (15 % of sidereal); it is
  reported beside them (below) because it is what the firmware and, most likely, the paper's
  figures use.
* **Settling**: the first ``settle_s`` seconds of each segment are excluded.
* **peak_error_pct** = max |v − v_sp| / |v_sp| × 100 over the windows; **rms_error_pct** =
  sqrt(mean((v − v_sp)²)) / |v_sp| × 100; **mean_error_pct** is the signed bias.
* **limit_cycle** is true when the velocity error, sampled with the same window sliding by 10 ms,
  shows a sustained oscillation: its autocorrelation has a repeat peak ≥ 0.3 at a lag between two
  windows and a third of the measured span, and its RMS exceeds both three times the measurement
  quantization (one count per window) and 1 % of the setpoint (an oscillation an operator would
  see on the paper's plots). Both conditions can fail: a smooth run has no repeat peak;
  quantization noise or a sub-percent ripple is below the amplitude threshold.
* The same numbers computed from the plant's true axis angle (not visible on the real telescope)
  are given as ``truth`` for comparison.
* **Per tick and per 10 ms** (``peak_error_tick_pct``, ``rms_error_tick_pct``,
  ``peak_error_10ms_pct``, ``rms_error_10ms_pct``): the firmware's own 5 ms QEI-difference rate
  (from the ``AXIS_AUX`` frames, as the §3.4 telemetry carries it) and the 10 ms status-frame
  difference, beside the 100 ms figures; these are what the paper's figures most likely show.
  ``disturbance_lines`` lists spectral lines of the 10 ms error with the gear-train line each
  matches; an oscillation whose period is such a forced line is reported as ``forced_line``, not
  as a limit cycle (see ``host/rate_metrics.py``).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = [
    "MEASUREMENT_METHOD",
    "window_rates",
    "segment_metrics",
    "write_reports",
    "plot_axes",
]

#: Smallest velocity-error RMS [% of setpoint] called a limit cycle (see the module docstring).
LIMIT_CYCLE_MIN_RMS_PCT = 1.0

MEASUREMENT_METHOD = __doc__.split("How velocity and errors are measured", 1)[1].split("\n", 1)[1].strip()


def window_rates(t_s: np.ndarray, pos: np.ndarray, window_s: float, step_s: float | None = None):
    """Average rate of ``pos`` over windows.

    Parameters
    ----------
    t_s : ndarray, shape (n,)
        Sample times [s], increasing, uniformly spaced.
    pos : ndarray, shape (n,)
        Position samples (any unit).
    window_s : float
        Window length [s].
    step_s : float, optional
        Window step [s]; default ``window_s`` (non-overlapping).

    Returns
    -------
    t_mid : ndarray, shape (m,)
        Window mid times [s].
    rate : ndarray, shape (m,)
        (pos[end] − pos[start]) / (t[end] − t[start]), in pos units per second.
    """
    t_s = np.asarray(t_s, float)
    pos = np.asarray(pos, float)
    if len(t_s) < 2:
        return np.empty(0), np.empty(0)
    dt = float(np.median(np.diff(t_s)))
    w = max(1, int(round(window_s / dt)))
    s = max(1, int(round((step_s or window_s) / dt)))
    starts = np.arange(0, len(t_s) - w, s)
    if len(starts) == 0:
        return np.empty(0), np.empty(0)
    ends = starts + w
    rate = (pos[ends] - pos[starts]) / (t_s[ends] - t_s[starts])
    return 0.5 * (t_s[starts] + t_s[ends]), rate


def _limit_cycle(err: np.ndarray, window_n: int, threshold: float) -> tuple[bool, float | None, float]:
    """Return (limit_cycle, period_samples, acf_peak) for an error series sampled every 10 ms."""
    e = err - err.mean()
    rms = float(np.sqrt(np.mean(e * e))) if len(e) else 0.0
    n = len(e)
    if n < 6 * window_n or rms == 0.0:
        return False, None, 0.0
    f = np.fft.rfft(e, 2 * n)
    acf = np.fft.irfft(f * np.conj(f))[:n]
    acf = acf / acf[0]
    lo, hi = 2 * window_n, n // 3
    if hi <= lo + 2:
        return False, None, 0.0
    seg = acf[lo:hi]
    k = int(np.argmax(seg))
    peak = float(seg[k])
    # a repeat peak must be a local maximum, not the edge of the decaying zero-lag lobe
    is_local_max = 0 < k < len(seg) - 1 and seg[k] >= seg[k - 1] and seg[k] >= seg[k + 1]
    # the decaying main lobe must have crossed below the peak before it (a true repeat)
    dipped = float(acf[window_n:lo + k].min()) < peak - 0.2 if lo + k > window_n else False
    sustained = is_local_max and dipped and peak >= 0.3
    return bool(sustained and rms > threshold), float(lo + k) if sustained else None, peak


@dataclass
class AxisTrace:
    """Host-side time series of one axis, sampled from the 10 ms status frames.

    Attributes (all ndarrays of shape (n,)): ``t_s`` [s], ``counts`` (unwrapped QEI counts),
    ``u`` (control effort, duty −1..1), ``mode`` (int), ``setpoint_arcsec_s``,
    ``current_a_a`` / ``current_b_a`` [A] (from the shunt ADC), ``truth_angle_rad`` (plant);
    and ``arcsec_per_count``, the incremental-encoder resolution at the axis that scales
    ``counts`` (the axis controller's, from the parameter file's encoder).
    """

    t_s: np.ndarray
    counts: np.ndarray
    u: np.ndarray
    mode: np.ndarray
    setpoint_arcsec_s: np.ndarray
    current_a_a: np.ndarray
    current_b_a: np.ndarray
    truth_angle_rad: np.ndarray
    arcsec_per_count: float
    tick_rate_arcsec_s: np.ndarray | None = None  # firmware's per-tick rate (AXIS_AUX), issue 9


def segment_metrics(
    trace: AxisTrace,
    t0_s: float,
    t1_s: float,
    setpoint_arcsec_s: float,
    window_ms: int,
    rated_current_a: float = 6.0,
) -> dict:
    """Error statistics of one axis over one segment (see the module docstring).

    Parameters
    ----------
    trace : AxisTrace
    t0_s, t1_s : float
        Measured span [s] (segment start + settle, segment end).
    setpoint_arcsec_s : float
        Signed commanded rate [arcsec/s]; must be non-zero.
    window_ms : int
        Velocity window [ms].
    rated_current_a : float
        Motor current rating for the over-current time [A] (paper §3.2: 6 A).

    Returns
    -------
    dict
        ``peak_error_pct``, ``rms_error_pct``, ``mean_error_pct``, ``limit_cycle``,
        ``limit_cycle_period_s``, ``mean_rate_arcsec_s``, ``stuck_fraction``, ``peak_current_a``,
        ``time_over_rating_s``, ``windows``, ``truth`` (same errors from the plant angle).

    Raises
    ------
    ValueError
        If the span holds fewer than two windows or the setpoint is zero.
    """
    if setpoint_arcsec_s == 0:
        raise ValueError("segment_metrics needs a non-zero setpoint")
    sel = (trace.t_s >= t0_s - 1e-9) & (trace.t_s <= t1_s + 1e-9)
    t = trace.t_s[sel]
    w_s = window_ms / 1000.0
    if len(t) < 3 or (t[-1] - t[0]) < 2 * w_s:
        raise ValueError(f"measured span {t0_s:.3f}-{t1_s:.3f} s holds fewer than two {window_ms} ms windows")
    sp = float(setpoint_arcsec_s)
    pos_arcsec = trace.counts[sel] * trace.arcsec_per_count
    _, v = window_rates(t, pos_arcsec, w_s)
    err = (v - sp) / abs(sp) * 100.0
    # sliding 10 ms-step version for the oscillation test
    _, v_slide = window_rates(t, pos_arcsec, w_s, 0.010)
    quant_pct = trace.arcsec_per_count / w_s / abs(sp) * 100.0
    dt = float(np.median(np.diff(t)))
    lc, period_n, acf_peak = _limit_cycle((v_slide - sp) / abs(sp) * 100.0, max(1, round(w_s / 0.010)),
                                          max(3 * quant_pct, LIMIT_CYCLE_MIN_RMS_PCT))
    dcounts = np.diff(trace.counts[sel])
    truth_pos = np.degrees(trace.truth_angle_rad[sel]) * 3600.0
    _, vt = window_rates(t, truth_pos, w_s)
    terr = (vt - sp) / abs(sp) * 100.0
    i_a, i_b = trace.current_a_a[sel], trace.current_b_a[sel]
    i_max = np.maximum(i_a, i_b)
    # issue 9: per-tick / 10 ms readings and forced lines (host/rate_metrics.py)
    from host.rate_metrics import classify_oscillation, rate_metrics

    fine = rate_metrics(t, trace.counts[sel], None if trace.tick_rate_arcsec_s is None
                        else trace.tick_rate_arcsec_s[sel], sp, trace.arcsec_per_count)
    lc, forced = classify_oscillation(lc, period_n * 0.010 if (lc and period_n) else None, fine["disturbance_lines"])
    return {
        "peak_error_pct": round(float(np.max(np.abs(err))), 3),
        "rms_error_pct": round(float(np.sqrt(np.mean(err**2))), 3),
        "mean_error_pct": round(float(np.mean(err)), 3),
        "limit_cycle": lc,
        "limit_cycle_period_s": round(period_n * 0.010, 3) if (lc and period_n) else None,
        "forced_line": forced,
        "acf_repeat_peak": round(acf_peak, 3),
        "mean_rate_arcsec_s": round(float(np.mean(v)), 4),
        "resolution_pct": round(quant_pct, 3),
        "stuck_fraction": round(float(np.mean(dcounts == 0)) if len(dcounts) else 0.0, 4),
        "peak_current_a": round(float(np.max(i_max)), 3),
        "time_over_rating_s": round(float(np.sum(i_max > rated_current_a) * dt), 3),
        "windows": int(len(v)),
        **fine,
        "truth": {
            "peak_error_pct": round(float(np.max(np.abs(terr))), 3),
            "rms_error_pct": round(float(np.sqrt(np.mean(terr**2))), 3),
        },
    }


def write_reports(out_dir: Path, report: dict) -> tuple[Path, Path]:
    """Write ``report.json`` and ``report.md`` into ``out_dir``.

    Parameters
    ----------
    report : dict
        Must hold ``scenario``, ``segments`` (list of dicts with ``name``, ``mode``,
        ``setpoint_arcsec_s``, ``peak_error_pct``, ``rms_error_pct``, ``limit_cycle``), ``method``.
    """
    jp = out_dir / "report.json"
    jp.write_text(json.dumps(report, indent=2, default=_json_default) + "\n", encoding="utf-8")
    mp = out_dir / "report.md"
    mp.write_text(_markdown(report), encoding="utf-8")
    return jp, mp


def _json_default(o):
    if isinstance(o, (np.integer,)):
        return int(o)
    if isinstance(o, (np.floating,)):
        return float(o)
    if isinstance(o, np.bool_):
        return bool(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def _markdown(r: dict) -> str:
    lines = [f"# schmidt-fil report: {r['scenario']}", ""]
    if r.get("description"):
        lines += [r["description"], ""]
    lines += [
        f"Simulated {r['simulated_s']:.1f} s in {r['wall_s']:.1f} s wall "
        f"({r['simulated_s'] / max(r['wall_s'], 1e-9):.1f}× real time); seed {r['seed']}; bus `{r['bus']['interface']}`.",
        "",
        "## Segments",
        "",
        "| segment | axis | mode | setpoint (″/s) | mean rate (″/s) | peak error % | rms error % | limit cycle | peak current (A) | s over 6 A | truth peak % |",
        "|---|---|---|---:|---:|---:|---:|---|---:|---:|---:|",
    ]
    tail = _fine_table(r)
    for s in r["segments"]:
        if s.get("peak_error_pct") is None:
            lines.append(f"| {s['name']} | {s['axis']} | {s['mode']} | {s['setpoint_arcsec_s']} | – | – | – | – | – | – | – |")
            continue
        lc = f"yes ({s['limit_cycle_period_s']} s)" if s["limit_cycle"] else "no"
        lines.append(
            f"| {s['name']} | {s['axis']} | {s['mode']} | {s['setpoint_arcsec_s']:g} | {s['mean_rate_arcsec_s']:g} | "
            f"{s['peak_error_pct']:.2f} | {s['rms_error_pct']:.2f} | {lc} | {s['peak_current_a']:.2f} | "
            f"{s['time_over_rating_s']:.2f} | {s['truth']['peak_error_pct']:.2f} |"
        )
    lines += tail
    lines += ["", "## How velocity and errors are measured", "", r["method"], ""]
    if r.get("controller"):
        lines += ["## Controller", ""]
        def fmt(d: dict) -> str:
            return ", ".join(f"{k} = {v:.6g}" if isinstance(v, float) else f"{k} = {v}"
                             for k, v in d.items() if not isinstance(v, dict))
        for axis, c in r["controller"].items():
            lines.append(f"- {axis}: " + fmt(c))
            if c.get("safety"):
                lines.append(f"- {axis} safety limits (boards/safety.py; scenario `safety:`): " + fmt(c["safety"]))
        lines.append("")
    if r.get("bus_stats"):
        b = r["bus_stats"]
        lines += ["## Bus", "", f"- frames: {b.get('frames')}, load {b.get('load_pct', 0):.2f} % (peak {b.get('peak_load_pct', 0):.2f} % over 100 ms)", ""]
    if r.get("maintenance"):
        lines += _maintenance(r)
    if r.get("boards"):
        if r.get("network"):
            lines += [f"Network `{r['network']}`: " + ", ".join(f"{n} (0x{v:02X})" for n, v in r["nodes"].items()), ""]
        lines += ["## Boards", "", "| board | malformed frames | CRC errors | state |", "|---|---:|---:|---|"]
        for name, b in r["boards"].items():
            lines.append(f"| {name} | {b.get('malformed_frames', 0)} | {b.get('crc_errors', '–')} | {b.get('state', '')} |")
        lines.append("")
        lines += _gateway_table(r["boards"])
        idents = {n: b for n, b in r["boards"].items() if b.get("identity")}
        if idents:
            lines += ["Identity and parameters read back by SDO at power-on (docs/canopen.md):", "",
                      "| board | device name | product | revision | serial | software | parameters |",
                      "|---|---|---:|---:|---:|---|---|"]
            for name, b in idents.items():
                i = b["identity"]
                params = ", ".join(f"{p['name'].split(': ')[-1]} {p['value']}" if p.get("value") is not None
                                   else f"{p['name'].split(': ')[-1]} –" for p in (b.get("parameters") or {}).values())
                lines.append(f"| {name} | {i['device_name']} | {i['product_code']} | 0x{i['revision']:08X} | "
                             f"0x{i['serial_number']:08X} | {i['software_version']} | {params} |")
            lines.append("")
    if r.get("room"):                      # issue 12: dome, weather station, display unit
        lines += ["## Room nodes", ""]
        for part, d in r["room"].items():
            lines.append(f"- {part}: " + ", ".join(f"{k} = {v}" for k, v in d.items()))
        lines += [f"- weather stops: {r.get('weather_stops', 0)}, motion commands refused by the host: "
                  f"{r.get('host_refused_commands', 0)}", ""]
    if r.get("errors"):
        lines += ["## Errors", ""] + [f"- {e}" for e in r["errors"]] + [""]
    return "\n".join(lines)


def _maintenance(r: dict) -> list[str]:
    """report.md section: the §5.2 maintenance quantities (host/maintenance.py), issue 12."""
    m = r["maintenance"]
    out = ["## Maintenance (paper §5.2)", "",
           f"From the frames the host received (host/maintenance.py). Nominal gear reduction: "
           + ", ".join(f"{a} {v}" for a, v in m["nominal_gear_reduction"].items()) + "."]
    if m["motors"]:
        out += ["", "| motor | node | TACH_STATUS frames | counts/rev | last speed (rad/s) | peak current (A) |",
                "|---|---:|---:|---:|---:|---:|"]
        for k, v in m["motors"].items():
            out.append(f"| {k} | 0x{v['node']:02X} | {v['frames']} | {v['counts_per_rev']} | "
                       f"{v['last_speed_rad_s']} | {v['peak_current_a']} |")
        rows = [s for s in r["segments"] if s.get("gear_reduction")]
        if rows:
            keys = list(m["motors"])
            out += ["", "Gear reduction (motor turns / axis turns over the settled segment; – = too little motion):", "",
                    "| segment | " + " | ".join(keys) + " |", "|---|" + "---:|" * len(keys)]
            for s in rows:
                out.append(f"| {s['name']} | " + " | ".join(
                    "–" if s["gear_reduction"].get(k) is None else f"{s['gear_reduction'][k]:.4f}" for k in keys) + " |")
    if m["aux_minus_main_arcsec"]:
        out += ["", "| axis | AUX_POSITION frames | compared | mean aux − main (″) | rms (″) | max abs (″) |",
                "|---|---:|---:|---:|---:|---:|"]
        for a, v in m["aux_minus_main_arcsec"].items():
            out.append(f"| {a} | {v['frames']} | {v['compared']} | {v.get('mean_arcsec', '–')} | "
                       f"{v.get('rms_arcsec', '–')} | {v.get('max_abs_arcsec', '–')} |")
    return out + [""]
def _gateway_table(boards: dict) -> list[str]:
    """report.md section: the USB-HID gateway's counters (the host's path, docs/usb-gateway.md),
    for each board row that has them."""
    out = []
    for name, b in boards.items():
        if "can_to_pc_latency_us" not in b:
            continue
        lat, usb = b["can_to_pc_latency_us"], b.get("usb_host") or {}
        wait = usb.get("out_wait_us") or {}

        def us(v):
            return "–" if v is None else f"{v:g}"

        out += [f"USB-HID gateway `{name}` (the host's node; docs/usb-gateway.md):", "",
                "| CAN → PC frames | dropped (queue full) | queue high water / depth | CAN → PC latency mean / max (µs) "
                "| PC → CAN frames | OUT reports refused | OUT wait mean / max (µs) | CAN errors (tx) |",
                "|---:|---:|---:|---:|---:|---:|---:|---:|",
                f"| {b['rx_frames']} | {b['rx_dropped']} | {b['queue_high_water']} / {b['queue_depth']} | "
                f"{us(lat['mean'])} / {us(lat['max'])} | {b['tx_frames']} | {b['out_malformed']} | "
                f"{us(wait.get('mean'))} / {us(wait.get('max'))} | {b['tx_errors']} |", ""]
    return out


def _fine_table(r: dict) -> list[str]:
    """report.md section: per-tick / 10 ms / 100 ms readings side by side, with the paper figure each
    corresponds to, and the forced lines (issue 9; host/rate_metrics.py)."""
    from host.rate_metrics import PAPER_FIGURES

    rows = [s for s in r["segments"] if s.get("peak_error_tick_pct") is not None or s.get("peak_error_10ms_pct") is not None]
    if not rows:
        return []
    out = ["", "## Rate error per tick, per 10 ms and per 100 ms", "",
           f"- **tick**: {PAPER_FIGURES['tick']}", f"- **10 ms**: {PAPER_FIGURES['10ms']}",
           f"- **100 ms**: {PAPER_FIGURES['100ms']}", "",
           "| segment | axis | peak tick % | rms tick % | one count per tick % | peak 10 ms % | rms 10 ms % | peak 100 ms % | rms 100 ms % | oscillation | lines (Hz: % → gear line) |",
           "|---|---|---:|---:|---:|---:|---:|---:|---:|---|---|"]

    def f(v):
        return "–" if v is None else f"{v:.2f}"

    for s in rows:
        if s.get("forced_line"):
            fl = s["forced_line"]
            osc = f"forced line {fl['gear_line']['line']} {fl['frequency_hz']:.3g} Hz (not a limit cycle)"
        elif s.get("limit_cycle"):
            osc = f"limit cycle ({s['limit_cycle_period_s']} s)"
        else:
            osc = "none"
        ls = "; ".join(f"{ln['frequency_hz']:.3g}: {ln['amplitude_pct']:.2f} → "
                       + (ln["gear_line"]["line"] if ln.get("gear_line") else "unmatched")
                       for ln in s.get("disturbance_lines") or []) or "–"
        out.append(f"| {s['name']} | {s['axis']} | {f(s.get('peak_error_tick_pct'))} | {f(s.get('rms_error_tick_pct'))} | "
                   f"{f(s.get('tick_resolution_pct'))} | {f(s.get('peak_error_10ms_pct'))} | {f(s.get('rms_error_10ms_pct'))} | "
                   f"{f(s.get('peak_error_pct'))} | {f(s.get('rms_error_pct'))} | {osc} | {ls} |")
    return out


def plot_axes(out_dir: Path, traces: dict[str, AxisTrace], segments: list[dict], window_ms: int) -> list[Path]:
    """PNG plots of velocity and control effort against time per axis (like paper Figs. 12–13).

    Velocity is the windowed QEI rate (sliding by 10 ms); the setpoint is drawn as a line and the
    control effort U (duty, right axis) dashed, as in the paper's figures.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = []
    for axis, tr in traces.items():
        if len(tr.t_s) < 3 or not np.any(tr.setpoint_arcsec_s != 0) and not np.any(tr.u != 0):
            continue
        fig, ax = plt.subplots(figsize=(11, 4.8))
        tm, v = window_rates(tr.t_s, tr.counts * tr.arcsec_per_count, window_ms / 1000.0, 0.010)
        ax.plot(tm, v, lw=0.8, color="C0", label=f"velocity (QEI, {window_ms} ms window)")
        ax.plot(tr.t_s, tr.setpoint_arcsec_s, lw=1.0, color="k", label="setpoint")
        ax.set_xlabel("time (s)")
        ax.set_ylabel("axis rate (arcsec/s)")
        ax2 = ax.twinx()
        ax2.plot(tr.t_s, tr.u * 100.0, "--", lw=0.8, color="C3", label="control effort U")
        ax2.set_ylabel("control effort U (% duty)")
        for s in segments:
            if s["axis"] in (axis, "both"):
                ax.axvline(s["t0_s"], color="0.7", lw=0.6)
        h1, l1 = ax.get_legend_handles_labels()
        h2, l2 = ax2.get_legend_handles_labels()
        ax.legend(h1 + h2, l1 + l2, loc="upper right", fontsize=8)
        ax.set_title(f"{axis.upper()} axis: velocity and control effort")
        fig.tight_layout()
        p = out_dir / f"{axis}_velocity_effort.png"
        fig.savefig(p, dpi=110)
        plt.close(fig)
        paths.append(p)
        # one zoomed plot per moving segment, where the interesting detail is
        for s in segments:
            if s["axis"] not in (axis, "both") or not s.get("setpoint_arcsec_s"):
                continue
            sel = (tr.t_s >= s["t0_s"]) & (tr.t_s <= s["t1_s"])
            if sel.sum() < 3:
                continue
            fig, ax = plt.subplots(figsize=(11, 4.2))
            if tr.tick_rate_arcsec_s is not None:
                ax.plot(tr.t_s[sel], tr.tick_rate_arcsec_s[sel], lw=0.5, color="0.65",
                        label="per 5 ms tick (firmware; like paper Figs. 6, 7, 12, 13)")
            tm, v = window_rates(tr.t_s[sel], tr.counts[sel] * tr.arcsec_per_count, window_ms / 1000.0, 0.010)
            ax.plot(tm, v, lw=0.8, color="C0", label=f"velocity (QEI, {window_ms} ms window)")
            ax.axhline(s["setpoint_arcsec_s"], color="k", lw=1.0, label="setpoint")
            ax.axvline(s["t0_s"] + s["settle_s"], color="0.6", lw=0.8, ls=":", label="end of settling")
            ax.set_xlabel("time (s)")
            ax.set_ylabel("axis rate (arcsec/s)")
            ax2 = ax2 = ax.twinx()
            ax2.plot(tr.t_s[sel], tr.u[sel] * 100.0, "--", lw=0.8, color="C3", label="control effort U")
            ax2.set_ylabel("control effort U (% duty)")
            ax.set_title(f"{axis.upper()} {s['name']} ({s['mode']}, {s['setpoint_arcsec_s']:g} arcsec/s)")
            h1, l1 = ax.get_legend_handles_labels()
            h2, l2 = ax2.get_legend_handles_labels()
            ax.legend(h1 + h2, l1 + l2, loc="upper right", fontsize=8)
            fig.tight_layout()
            p = out_dir / f"{axis}_{_slug(s['name'])}.png"
            fig.savefig(p, dpi=110)
            plt.close(fig)
            paths.append(p)
    return paths


def _slug(s: str) -> str:
    return "".join(c if c.isalnum() or c in "-_" else "-" for c in s)
