"""Rate errors the way the controller and the paper see them, and forced lines vs limit cycles.

Three readings of the same QEI count, from short to long (all as % of the setpoint):

* **per tick (5 ms)** — ``peak_error_tick_pct``, ``rms_error_tick_pct``: the rate the axis
  firmware itself computes every 5 ms tick from the QEI difference (``qei_delta × 0.01148″ / 5 ms``)
  and feeds its PI with. The host receives it in every ``AXIS_AUX`` frame (the last tick's
  ``qei_delta``, one frame per 10 ms, so every second tick is seen) — the same sample the RS232
  telemetry of §3.4 carries. This is most likely what the paper's velocity figures plot (Figs. 6,
  7, 12, 13: "≈ 25 %" at 15″/s is a one-count reading). One count per tick is 2.30″/s: 15.3 % of
  15″/s, 0.38 % of 600″/s. At 15″/s a tick holds 6.53 counts, so a reading can only be 6 or 7
  counts (−8.2 %, +7.1 %) or one further (−23.5 %, +22.4 %).
* **10 ms** — ``peak_error_10ms_pct``, ``rms_error_10ms_pct``: the difference of the cumulative
  QEI count between consecutive ``AXIS_STATUS`` frames (the §3.4 10 ms samples).
* **100 ms** — the report's operator window (``peak_error_pct``; see :mod:`host.report`).

**Forced lines.** The 10 ms rate error's spectrum (Hann window) is searched for lines; each line's
frequency is compared with the gear-train orders (:mod:`plant.gear_train_disturbance`) at the
segment's measured mean rate. A match is within ``max(2 / span, 5 %)`` of the line's frequency
(the spectral resolution of the measured span, or the speed's own variation). An oscillation the
100 ms limit-cycle detector flags is reported as a **forced disturbance line**, not a limit cycle,
when its period matches (±15 %) a spectral line that matches a gear order: its frequency follows
the speed, so it is forced by position, not sustained by the loop.
"""

from __future__ import annotations

import numpy as np

from plant.gear_train_disturbance import LINE_ORDERS, line_frequency_hz

__all__ = ["tick_metrics", "window_10ms_metrics", "spectral_lines", "match_gear_line",
           "classify_oscillation", "rate_metrics", "PAPER_FIGURES"]

#: Which paper figure each reading corresponds to (written into report.md and the plots).
PAPER_FIGURES = {
    "tick": "per 5 ms tick (firmware's QEI difference; most likely what paper Figs. 6, 7, 12, 13 plot)",
    "10ms": "per 10 ms (status-frame QEI difference; the §3.4 telemetry sample spacing)",
    "100ms": "per 100 ms window (operator's smoothed reading; no paper figure)",
}

#: Smallest line amplitude reported [% of setpoint, peak] and its margin above the spectral floor.
MIN_LINE_PCT = 0.5
LINE_OVER_FLOOR = 6.0
MATCH_REL = 0.05
PERIOD_REL = 0.15


def _err_pct(rate, sp):
    return (np.asarray(rate, float) - sp) / abs(sp) * 100.0


def tick_metrics(tick_rate_arcsec_s: np.ndarray, setpoint_arcsec_s: float) -> dict:
    """Peak and RMS of the per-tick rate error.

    Parameters
    ----------
    tick_rate_arcsec_s : ndarray, shape (n,)
        The firmware's per-tick rate readings [″/s] (``AXIS_AUX`` qei_delta × 0.01148 / 0.005).
    setpoint_arcsec_s : float
        Non-zero setpoint [″/s].

    Returns
    -------
    dict
        ``peak_error_tick_pct``, ``rms_error_tick_pct`` (``None`` when there are no samples).
    """
    if len(tick_rate_arcsec_s) == 0:
        return {"peak_error_tick_pct": None, "rms_error_tick_pct": None}
    e = _err_pct(tick_rate_arcsec_s, setpoint_arcsec_s)
    return {"peak_error_tick_pct": round(float(np.max(np.abs(e))), 3),
            "rms_error_tick_pct": round(float(np.sqrt(np.mean(e * e))), 3)}


def window_10ms_metrics(t_s: np.ndarray, pos_arcsec: np.ndarray, setpoint_arcsec_s: float) -> tuple[dict, np.ndarray, float]:
    """Peak and RMS of the rate error over consecutive 10 ms samples.

    Returns
    -------
    metrics : dict
        ``peak_error_10ms_pct``, ``rms_error_10ms_pct``.
    err : ndarray
        The 10 ms error series [% of setpoint] (for :func:`spectral_lines`).
    dt : float
        Its sample spacing [s].
    """
    t = np.asarray(t_s, float)
    x = np.asarray(pos_arcsec, float)
    if len(t) < 3:
        return {"peak_error_10ms_pct": None, "rms_error_10ms_pct": None}, np.empty(0), 0.01
    v = np.diff(x) / np.diff(t)
    e = _err_pct(v, setpoint_arcsec_s)
    return ({"peak_error_10ms_pct": round(float(np.max(np.abs(e))), 3),
             "rms_error_10ms_pct": round(float(np.sqrt(np.mean(e * e))), 3)},
            e, float(np.median(np.diff(t))))


def spectral_lines(err_pct: np.ndarray, dt_s: float, max_lines: int = 3) -> list[dict]:
    """Strongest spectral lines of an error series.

    The amplitude is the Hann-weighted DFT evaluated at the line's interpolated frequency (so a
    line between two bins is not underestimated). A line is a local maximum of the Hann-windowed amplitude spectrum at least
    :data:`LINE_OVER_FLOOR` times the median amplitude (the floor) and at least
    :data:`MIN_LINE_PCT` peak. The DC bin and its neighbour are skipped.

    Parameters
    ----------
    err_pct : ndarray, shape (n,)
        Error samples [% of setpoint], uniformly spaced.
    dt_s : float
        Sample spacing [s].
    max_lines : int
        At most this many, strongest first.

    Returns
    -------
    list of dict
        ``frequency_hz`` (parabolic interpolation between bins), ``amplitude_pct`` (peak of the
        sinusoid), strongest first.
    """
    e = np.asarray(err_pct, float)
    n = len(e)
    if n < 16:
        return []
    w = np.hanning(n)
    spec = np.abs(np.fft.rfft((e - e.mean()) * w)) * 2.0 / w.sum()
    floor = float(np.median(spec[2:])) if len(spec) > 3 else 0.0
    out = []
    for k in range(2, len(spec) - 1):
        a = spec[k]
        if a < spec[k - 1] or a < spec[k + 1] or a < MIN_LINE_PCT or a < LINE_OVER_FLOOR * floor:
            continue
        y0, y1, y2 = spec[k - 1], a, spec[k + 1]
        den = y0 - 2 * y1 + y2
        d = 0.5 * (y0 - y2) / den if den != 0 else 0.0
        fk = (k + d) / (n * dt_s)
        # amplitude from a Hann-weighted DFT at the interpolated frequency (no scalloping loss)
        amp = 2.0 * abs(np.sum(w * (e - e.mean()) * np.exp(-2j * np.pi * fk * dt_s * np.arange(n)))) / w.sum()
        out.append({"frequency_hz": round(float(fk), 4), "amplitude_pct": round(float(amp), 3)})
    out.sort(key=lambda x: -x["amplitude_pct"])
    return out[:max_lines]


def match_gear_line(frequency_hz: float, rate_arcsec_s: float, span_s: float) -> dict | None:
    """The gear-train line whose frequency at ``rate_arcsec_s`` matches ``frequency_hz``, if any.

    Parameters
    ----------
    frequency_hz : float
    rate_arcsec_s : float
        Measured mean axis rate [″/s].
    span_s : float
        Measured span [s]; sets the spectral resolution 1/span.

    Returns
    -------
    dict or None
        ``{"line", "order", "expected_hz"}`` of the closest line within ``max(2/span, 5 %)``.
    """
    best = None
    for name, order in LINE_ORDERS.items():
        f = line_frequency_hz(order, rate_arcsec_s)
        tol = max(2.0 / span_s, MATCH_REL * f)
        d = abs(frequency_hz - f)
        if d <= tol and (best is None or d < best[0]):
            best = (d, name, order, f)
    if best is None:
        return None
    return {"line": best[1], "order": round(best[2], 3), "expected_hz": round(best[3], 4)}


def classify_oscillation(limit_cycle: bool, period_s: float | None, lines: list[dict]) -> tuple[bool, dict | None]:
    """Tell a limit cycle from a forced gear line.

    Parameters
    ----------
    limit_cycle : bool
        The 100 ms detector's verdict (:mod:`host.report`).
    period_s : float or None
        Its period [s].
    lines : list of dict
        :func:`spectral_lines` entries, each with ``gear_line`` (a :func:`match_gear_line` result
        or ``None``).

    Returns
    -------
    (limit_cycle, forced_line)
        ``limit_cycle`` False and the matching line when the period belongs to a forced gear line.
    """
    if not limit_cycle or not period_s:
        return limit_cycle, None
    f = 1.0 / period_s
    for ln in lines:
        if ln.get("gear_line") and abs(ln["frequency_hz"] - f) <= PERIOD_REL * f:
            return False, ln
    return limit_cycle, None


def rate_metrics(t_s: np.ndarray, counts: np.ndarray, tick_rate_arcsec_s: np.ndarray | None,
                 setpoint_arcsec_s: float, arcsec_per_count: float) -> dict:
    """Per-tick and 10 ms errors plus spectral lines of one segment's measured span.

    Parameters
    ----------
    t_s, counts : ndarray, shape (n,)
        Host sample times [s] and unwrapped QEI counts of the span (10 ms apart).
    tick_rate_arcsec_s : ndarray, shape (n,) or None
        The firmware's per-tick rate seen at each sample (``None``: not recorded).
    setpoint_arcsec_s : float
        Non-zero setpoint [″/s].
    arcsec_per_count : float
        QEI resolution at the axis [″].

    Returns
    -------
    dict
        ``peak_error_tick_pct``, ``rms_error_tick_pct``, ``peak_error_10ms_pct``,
        ``rms_error_10ms_pct``, ``tick_resolution_pct`` (one count per tick), ``disturbance_lines``
        (list of ``frequency_hz``, ``amplitude_pct``, ``gear_line``).
    """
    sp = float(setpoint_arcsec_s)
    out = tick_metrics(tick_rate_arcsec_s if tick_rate_arcsec_s is not None else np.empty(0), sp)
    m10, err10, dt = window_10ms_metrics(t_s, np.asarray(counts, float) * arcsec_per_count, sp)
    out.update(m10)
    out["tick_resolution_pct"] = round(arcsec_per_count / 0.005 / abs(sp) * 100.0, 3)
    span = float(t_s[-1] - t_s[0]) if len(t_s) > 1 else 0.0
    mean_rate = float((counts[-1] - counts[0]) * arcsec_per_count / span) if span > 0 else sp
    lines = spectral_lines(err10, dt)
    for ln in lines:
        ln["gear_line"] = match_gear_line(ln["frequency_hz"], mean_rate, span) if span > 0 else None
    out["disturbance_lines"] = lines
    return out
