"""Residual analysis: where does the fitted model miss?

Four views of the (decimated) residual ``r = y − ŷ``:

* :func:`velocity_profile` — binned mean residual against velocity: asymmetry between the
  directions (``asymmetric_friction``) and a bump at low speed (Stribeck).
* :func:`position_spectrum` — Lomb–Scargle periodogram of the residual against *position*, over
  the samples in motion, in cycles per unit position (cycles/rad or cycles/m): gear or
  motor-revolution ripple, imbalance.
* :func:`time_spectrum` — the same against time, in Hz.
* :func:`reversal_profile` — residual around velocity reversals, signed by the new direction of
  motion: pre-sliding, hysteresis, backlash.

The periodogram is normalised so that its value at a frequency is the share of the residual
variance a single sinusoid at that frequency explains (0..1). Its false-alarm probability for
``M`` independent frequencies and white noise is about ``M·(1−z)^((n_eff−3)/2)``; we use the AR(1)
effective sample size ``n_eff`` because the residuals are autocorrelated.
"""

from __future__ import annotations

import math


import numpy as np
from scipy import signal

from plant.calibration.fit import STANDSTILL_FRAC, effective_n, true_runs

__all__ = ["velocity_profile", "position_spectrum", "time_spectrum", "reversal_profile", "reversal_dwell_swings", "find_peaks",
           "moving_mask", "summarize", "whiteness"]

#: fewest cycles over the travel (position) or the record (time) for a periodic term to be identifiable;
#: the position spectrum searches from one cycle and :func:`find_peaks` drops maxima below this
#: (session 27: a maximum at 2.12 cycles was the grid's first point and never a peak)
MIN_CYCLES = 2.0


#: A sample is in motion above this share of the 95th-percentile speed (:func:`moving_mask`; assumed:
#: above the standstill rule's 2 %, so that the velocity's sign is that of a motion, not of noise).
MOVING_FRAC = 0.05


def moving_mask(dq: np.ndarray, frac: float = MOVING_FRAC) -> np.ndarray:
    """Samples in motion: ``|dq|`` above ``frac`` of its 95th percentile."""
    v95 = float(np.percentile(np.abs(dq), 95)) if dq.size else 0.0
    return np.abs(dq) > frac * v95


def velocity_profile(dq: np.ndarray, resid: np.ndarray, n_bins: int = 30) -> dict:
    """Binned residual against velocity.

    Returns
    -------
    dict
        ``centers``, ``mean``, ``std``, ``count`` (arrays over bins with ≥ 5 samples) and
        ``asymmetry``: the mean residual for positive minus negative velocities, and the slopes of
        the residual against velocity on each side (evidence of asymmetric viscous friction).
    """
    edges = np.quantile(dq, np.linspace(0, 1, n_bins + 1))
    edges = np.unique(edges)
    idx = np.clip(np.digitize(dq, edges) - 1, 0, len(edges) - 2)
    centers, mean, std, count = [], [], [], []
    for b in range(len(edges) - 1):
        m = idx == b
        if m.sum() < 5:
            continue
        centers.append(float(np.mean(dq[m])))
        mean.append(float(np.mean(resid[m])))
        std.append(float(np.std(resid[m])))
        count.append(int(m.sum()))
    mov = moving_mask(dq)
    pos, neg = mov & (dq > 0), mov & (dq < 0)
    out = {"centers": np.array(centers), "mean": np.array(mean), "std": np.array(std), "count": np.array(count)}

    def slope(m: np.ndarray) -> float:
        if m.sum() < 10:
            return float("nan")
        return float(np.polyfit(dq[m], resid[m], 1)[0])

    out["asymmetry"] = {
        "mean_pos": float(resid[pos].mean()) if pos.any() else float("nan"),
        "mean_neg": float(resid[neg].mean()) if neg.any() else float("nan"),
        "slope_pos": slope(pos),
        "slope_neg": slope(neg),
    }
    return out


def _lomb(x: np.ndarray, r: np.ndarray, freqs: np.ndarray) -> np.ndarray:
    """Normalised Lomb–Scargle power: share of var(r) explained by one sinusoid at each frequency."""
    r = r - r.mean()
    var = float(r @ r)
    if var <= 0 or x.size < 10:
        return np.zeros_like(freqs)
    # in chunks of frequencies: scipy's lombscargle holds (samples × frequencies) temporaries,
    # which for 10⁵ samples and 4000 frequencies is gigabytes (issue 7)
    w = 2 * np.pi * freqs
    chunk = max(1, int(2_000_000 // max(x.size, 1)))
    p = np.concatenate([signal.lombscargle(x, r, w[i : i + chunk]) for i in range(0, w.size, chunk)])
    return np.clip(2.0 * p / var, 0.0, 1.0)


def _grid_share(vals: np.ndarray, n_used: int, d: float, fmin: float, fmax: float, pad: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """FFT periodogram of values on a uniform grid (empty cells 0), normalised approximately as the
    share of the variance one sinusoid explains; exact shares are recomputed at the peaks."""
    n = vals.size
    nfft = 1 << int(math.ceil(math.log2(max(pad * n, 16))))
    X = np.fft.rfft(vals, nfft)
    f = np.fft.rfftfreq(nfft, d)
    ss = float(vals @ vals)
    share = 2.0 * np.abs(X) ** 2 / max(n_used, 1) / ss if ss > 0 else np.zeros(f.size)
    m = (f >= fmin) & (f <= fmax)
    return f[m], np.clip(share[m], 0.0, 1.0)


def exact_share(x: np.ndarray, r: np.ndarray, freq: float) -> float:
    """Share of the variance of ``r`` explained by one sinusoid of frequency ``freq`` in ``x`` (0..1)."""
    r0 = r - r.mean()
    v = float(r0 @ r0)
    if v <= 0:
        return 0.0
    X = np.column_stack([np.sin(2 * np.pi * freq * x), np.cos(2 * np.pi * freq * x), np.ones_like(x)])
    coef, *_ = np.linalg.lstsq(X, r, rcond=None)
    e = r - X @ coef
    return float(max(0.0, 1.0 - float(e @ e) / v))


def position_spectrum(q: np.ndarray, dq: np.ndarray, resid: np.ndarray, n_freq: int | None = None) -> dict:
    """Residual spectrum against position over the samples in motion.

    The residual is averaged in uniform position bins (one bin per median position step between
    samples; at most 2^17 bins) and Fourier-transformed (angular resampling, as in order
    tracking): O(n log n) time and O(n) memory, where a Lomb–Scargle sum over thousands of trial
    frequencies cost seconds and gigabytes on long records. Shares at the peaks are recomputed
    exactly from the raw samples (:func:`find_peaks`).

    Returns
    -------
    dict
        ``freq`` [cycles per unit position] from one cycle over the travel, ``share`` (0..1), ``n``
        samples used, ``n_eff``, the raw ``x``, ``r`` used, and ``f_min`` (:data:`MIN_CYCLES` over
        the travel), below which :func:`find_peaks` reports no peak.
    """
    mov = moving_mask(dq)
    x, r = q[mov], resid[mov]
    if x.size < 50:
        return {"freq": np.array([]), "share": np.array([]), "n": int(x.size), "n_eff": 0.0, "x": x, "r": r}
    span = float(x.max() - x.min())
    step = float(np.median(np.abs(np.diff(x)))) or span / x.size
    step = max(step, span / 2**17)
    idx = np.minimum(((x - x.min()) / step).astype(np.int64), int(span / step))
    nb = int(idx.max()) + 1
    cnt = np.bincount(idx, minlength=nb)
    rr = r - r.mean()
    sums = np.bincount(idx, weights=rr, minlength=nb)
    vals = np.where(cnt > 0, sums / np.maximum(cnt, 1), 0.0)
    vals[cnt > 0] -= vals[cnt > 0].mean()
    # the grid starts at one cycle so that a maximum just above the rule's two cycles is a local maximum
    # (session 27): find_peaks drops maxima below ``f_min``
    freqs, share = _grid_share(vals, int((cnt > 0).sum()), step, 1.0 / span, 0.5 / step)
    return {"freq": freqs, "share": share, "n": int(x.size), "n_eff": effective_n(r), "x": x, "r": r,
            "f_min": MIN_CYCLES / span}


def time_spectrum(t: np.ndarray, resid: np.ndarray, f_max_hz: float | None = None, n_freq: int | None = None) -> dict:
    """Residual spectrum against time (FFT on the sample grid; dropped standstill samples count as 0).

    Parameters
    ----------
    f_max_hz : float, optional
        Upper frequency; default 0.8 of the Nyquist frequency of ``t`` (the decimation pass band).

    Returns
    -------
    dict
        ``freq`` [Hz] from :data:`MIN_CYCLES` over the record, ``share`` (0..1), ``n``, ``n_eff``,
        raw ``x`` (= t), ``r``. Unlike the position spectrum the grid does not start lower: a line of
        about two cycles over a record with few reversals is a slow function of the position too,
        and took the place of a load-dependent friction on blind record 55 (session 27).
    """
    dt = float(np.median(np.diff(t)))
    T = float(t[-1] - t[0])
    idx = np.round((t - t[0]) / dt).astype(np.int64)
    vals = np.zeros(int(idx[-1]) + 1)
    rr = resid - resid.mean()
    vals[idx] = rr
    fmax = f_max_hz if f_max_hz is not None else 0.8 * 0.5 / dt
    freqs, share = _grid_share(vals, t.size, dt, MIN_CYCLES / T, fmax)
    return {"freq": freqs, "share": share, "n": int(t.size), "n_eff": effective_n(resid), "x": t, "r": resid}


def find_peaks(spec: dict, n_peaks: int = 3, min_share: float = 0.0, fap_max: float = 1.0) -> list[dict]:
    """Strongest local maxima of a spectrum from :func:`position_spectrum`/:func:`time_spectrum`.

    Returns
    -------
    list of dict
        ``{"frequency", "share", "fap"}`` sorted by share, at most ``n_peaks``; ``fap`` is the
        false-alarm probability (white noise, ``n_eff`` samples, independent frequencies ≈ span × T).
        Only local maxima of the spectrum count, and none below ``spec["f_min"]``: a maximum just
        above that limit is found because the spectrum's grid starts lower (session 27). A grid
        maximum below the limit is located by the vertex of the parabola through it and its two
        neighbours, and is reported there if that lies at or above the limit.
    """
    f, s = spec["freq"], spec["share"]
    if f.size < 3:
        return []
    idx, _ = signal.find_peaks(s)
    f_min = spec.get("f_min", 0.0)
    at = {int(i): float(f[i]) for i in idx}
    for i in idx:
        if f[i] < f_min:
            # the grid's maximum lies below the limit; the spectrum's own maximum may not: the vertex of
            # the parabola through the three grid points (session 27)
            den = s[i - 1] - 2.0 * s[i] + s[i + 1]
            vertex = f[i] + 0.5 * (f[i + 1] - f[i]) * (s[i - 1] - s[i + 1]) / den if den < 0 else f[i]
            at[int(i)] = float(vertex)
    idx = np.array([i for i in idx if at[int(i)] >= f_min], dtype=int)
    idx = idx[np.argsort(s[idx])[::-1]]
    n_eff = max(spec.get("n_eff", spec["n"]), 4.0)
    m_indep = max(spec["n"] / 2.0, 1.0)
    out = []
    for i in idx[: 8 * n_peaks]:
        fi = at[int(i)]
        z = exact_share(spec["x"], spec["r"], fi) if "x" in spec else float(s[i])
        fap = min(1.0, m_indep * (1.0 - z) ** ((n_eff - 3.0) / 2.0)) if z < 1 else 0.0
        if z < min_share or fap > fap_max:
            continue
        # avoid near-duplicates (within 2 % of a stronger peak)
        if any(abs(fi - p["frequency"]) < 0.02 * p["frequency"] for p in out):
            continue
        out.append({"frequency": fi, "share": z, "fap": fap})
    out.sort(key=lambda p: -p["share"])
    return out[:n_peaks]


def reversal_indices(dq: np.ndarray) -> list[tuple[int, float]]:
    """Velocity reversals: ``(index, direction of the new motion)`` for every sign change of the
    moving samples (:func:`moving_mask` at 20 %), the index at the smallest ``|dq|`` between them."""
    mov = moving_mask(dq, 0.2)
    sgn = np.sign(dq) * mov
    nz = np.flatnonzero(sgn)
    ch = np.flatnonzero(sgn[nz[:-1]] != sgn[nz[1:]])
    return [(int(nz[i] + np.argmin(np.abs(dq[nz[i] : nz[i + 1] + 1]))), float(sgn[nz[i + 1]])) for i in ch]


def _window_samples(t: np.ndarray, window_s: float) -> int:
    return max(int(round(window_s / float(np.median(np.diff(t))))), 2)


def counted_reversals(t: np.ndarray, dq: np.ndarray, window_s: float = 0.15) -> list[int]:
    """Indices of the velocity reversals (:func:`reversal_indices`) with their whole ±``window_s``
    [s] inside the record (those :func:`reversal_profile` averages), in time order."""
    w = _window_samples(t, window_s)
    return [k for k, _ in reversal_indices(dq) if k - w >= 0 and k + w < dq.size]


def count_reversals(t: np.ndarray, dq: np.ndarray, window_s: float = 0.15) -> int:
    """Number of :func:`counted_reversals`."""
    return len(counted_reversals(t, dq, window_s))


def reversal_profile(t: np.ndarray, dq: np.ndarray, resid: np.ndarray, window_s: float = 0.15) -> dict:
    """Residual around velocity reversals, signed by the direction of the new motion.

    Returns
    -------
    dict
        ``lag_s`` (time since reversal), ``mean`` (mean signed residual over reversals),
        ``n_reversals``, ``share_pct`` (share of the residual's sum of squares that falls within
        ±window of a reversal) and ``time_share_pct`` (share of the samples within those windows;
        a much larger energy share than time share flags reversal effects).
    """
    dt = float(np.median(np.diff(t)))
    w = _window_samples(t, window_s)
    rev = reversal_indices(dq)
    lags = np.arange(-w, w + 1)
    prof = []
    inwin = np.zeros(resid.size, bool)
    for k, direction in rev:
        if k - w < 0 or k + w >= resid.size:
            continue
        prof.append(direction * resid[k - w : k + w + 1])
        inwin[k - w : k + w + 1] = True
    total = float(resid @ resid) or 1.0
    return {
        "lag_s": lags * dt,
        "mean": np.mean(prof, axis=0) if prof else np.zeros(lags.size),
        "n_reversals": len(prof),
        "share_pct": 100.0 * float(resid[inwin] @ resid[inwin]) / total,
        "time_share_pct": 100.0 * float(inwin.mean()),
    }


#: :func:`reversal_dwell_swings` (session 45). Assumed, none fitted: a moving run lasts at least
#: 0.1 s (a reversal joins two motions, not two noise excursions); a gap longer than 1 s between two
#: runs is a stop whose torque the servo sets, not a reversal; the dwell is the samples within 2
#: position quanta of the turning point (the quantiser's ±1 plus a count of sub-quantum creep); the
#: torque is median-filtered over 5 samples within the dwell, so that its noise (a few % of Fc on
#: both benchmark generators) adds no range.
DWELL_MIN_RUN_S = 0.1
DWELL_MAX_GAP_S = 1.0
DWELL_QUANTA = 2
DWELL_MEDIAN = 5


def reversal_dwell_swings(prep) -> np.ndarray:
    """How much the torque changes while the axis stays at each velocity reversal's turning point.

    At a reversal the friction torque steps by about ``2·Fc``. A pre-sliding (LuGre bristle with
    ``Fc/σ0`` of ``n`` position quanta) makes that step a function of the displacement: within
    :data:`DWELL_QUANTA` quanta of the turning point (half a quantum more for the quantiser) the
    bristle force changes by at most ``2·(1 − exp(−(DWELL_QUANTA + ½)/n))·Fc``. With stiff bristles
    the axis sticks instead: the servo ramps the torque through the static band (from about ``+Fc``
    to ``−Fs``) while the position stays within a count, and the axis breaks away afterwards. This
    measures, per reversal, the range of the (median-filtered) logged torque over the samples whose
    logged position is within :data:`DWELL_QUANTA` quanta of the turning point.

    A reversal is a moving run (``|dq| ≥`` :data:`plant.calibration.fit.STANDSTILL_FRAC` × the
    95th-percentile speed, the standstill rule of :func:`plant.calibration.fit.prepare`, for at least :data:`DWELL_MIN_RUN_S`) followed within
    :data:`DWELL_MAX_GAP_S` by a run of the other sign; the turning point is the extreme logged
    position between them. Docs: docs/calibration.md, "Session 45".

    Parameters
    ----------
    prep : plant.calibration.fit.Prepared
        Uses the full-rate ``dq`` [rad/s or m/s], ``y`` [N·m or N], ``dt_s``,
        ``position_resolution`` and the record's logged position (its last ``dq.size`` samples).

    Returns
    -------
    ndarray, shape (n,)
        The torque range [N·m or N] at each reversal, in time order; empty if none, or if the
        position is not quantised (``position_resolution`` 0: no turning point to stay at).
    """
    from scipy.ndimage import median_filter
    dq, y = prep.dq, prep.y
    res_q = float(prep.position_resolution)
    if dq.size < 10 or not res_q > 0:
        return np.zeros(0)
    pos = np.asarray(prep.record.position, dtype=float)[-dq.size:]
    dt = prep.dt_s
    v_still = STANDSTILL_FRAC * float(np.percentile(np.abs(dq), 95))
    mov = np.abs(dq) >= v_still
    runs = [(a, b, float(np.sign(np.median(dq[a:b])))) for a, b in true_runs(mov) if (b - a) * dt >= DWELL_MIN_RUN_S]
    out = []
    for (a1, b1, s1), (a2, b2, s2) in zip(runs[:-1], runs[1:]):
        if s1 * s2 >= 0 or (a2 - b1) * dt > DWELL_MAX_GAP_S:
            continue
        seg = pos[a1:b2]
        k = int(np.argmax(seg)) if s1 > 0 else int(np.argmin(seg))
        near = np.abs(seg - seg[k]) <= (DWELL_QUANTA + 0.5) * res_q
        # the contiguous stretch around the turning point
        lo = k - int(np.argmin(near[k::-1])) + 1 if not near[: k + 1].all() else 0
        hi = k + int(np.argmin(near[k:])) if not near[k:].all() else near.size
        tq = y[a1 + lo: a1 + hi]
        if tq.size >= DWELL_MEDIAN:
            tq = median_filter(tq, DWELL_MEDIAN, mode="nearest")
        out.append(float(np.ptp(tq)) if tq.size else 0.0)
    return np.asarray(out, dtype=float)


def summarize(prep, resid: np.ndarray) -> dict:
    """All four views for a prepared record's decimated residual (used by the report)."""
    return {
        "velocity": velocity_profile(prep.dq_dec, resid),
        "position": position_spectrum(prep.q_dec, prep.dq_dec, resid),
        "time": time_spectrum(prep.t_dec, resid),
        "reversal": reversal_profile(prep.t_dec, prep.dq_dec, resid),
    }


def whiteness(resid: np.ndarray) -> float:
    """Lag-1 autocorrelation of the residual (0 for white noise)."""
    r = resid - resid.mean()
    d = float(r @ r)
    return float(r[1:] @ r[:-1] / d) if d > 0 else 0.0


