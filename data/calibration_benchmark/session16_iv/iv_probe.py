"""Session 16 prototype: an instrumental-variable (IV) inertia, so the encoder's quantisation noise
in the measured acceleration no longer lets a smooth column stand in for ``J·ddq``.

Patches ``plant.calibration.fit`` (loaded by ``dev_runner.py`` through ``PATCH=``):

- ``design_full`` appends a column ``__iv``: the acceleration of the raw position low-passed by a
  zero-phase 4th-order Butterworth whose cut-off is the lowest at which the removed part's
  variance is still at most the quantisation variance ``res²/12`` (Morozov's discrepancy
  principle: the smoothest curve the encoder's own resolution allows; ``res`` is the position
  resolution ``prepare`` reads off the record). It is decimated with the other columns.
- ``_solve`` with that column present does two-stage least squares: the inertia column is
  replaced by its projection on the instruments (``__iv`` and every other regressor, which are
  their own instruments), the bounded least squares of the torque on those columns gives the
  parameters, the residual is ``y − X·θ`` with the measured columns. ``__iv`` gets coefficient 0.

Off for EMPS records (the benchmark's IDIM-LS reproduction) and when ``IV`` is unset.
Run from the repository root::

    IV=1 PATCH=data/calibration_benchmark/session16_iv/iv_probe.py \
        .venv/bin/python data/calibration_benchmark/session12_constancy/dev_runner.py OUT.json [SEEDS]
"""
import os

import numpy as np
from scipy import optimize, signal

import plant.calibration.fit as F
import plant.calibration.loop as L

_IV_CACHE: dict = {}


def iv_acceleration(prep) -> np.ndarray | None:
    """Full-rate instrument acceleration (after the border), or None when not applicable."""
    key = id(prep)
    if key in _IV_CACHE:
        return _IV_CACHE[key][1]
    rec = prep.record
    out = None
    res = prep.position_resolution
    if rec.extra.get("format") != "emps" and res > 0:
        fs = 1.0 / prep.dt_s
        q = rec.position
        target = res * res / 12.0

        def smooth(fc):
            b, a = signal.butter(4, fc / (fs / 2))
            return signal.filtfilt(b, a, q, padtype="odd", padlen=3 * (max(len(a), len(b)) - 1))

        def removed(fc):
            return float(np.var((q - smooth(fc))[F.N_BORDER:-F.N_BORDER]))

        if os.environ.get("IV") == "lines":
            # keep the Fourier bins of the (detrended) position that stand above the quantisation
            # floor at a false-alarm probability of 1e-3 over all bins (white noise of variance
            # res²/12 gives E|X_k|² = n·res²/12, exponentially distributed)
            n = q.size
            idx = np.arange(n)
            x = q - np.polyval(np.polyfit(idx, q, 1), idx)
            Xf = np.fft.rfft(x)
            thr = n * target * np.log(Xf.size / 1e-3)
            Xf[np.abs(Xf) ** 2 <= thr] = 0.0
            qs = np.fft.irfft(Xf, n=n) + (q - x)
            fc = float(np.count_nonzero(Xf))
        elif os.environ.get("IV") == "wiener":
            # Wiener weights from Welch's PSD of the position against the white quantisation floor
            # res²/12 spread over 0…fs/2 (one-sided density res²/(6·fs))
            x = q - np.polyval(np.polyfit(np.arange(q.size), q, 1), np.arange(q.size))
            f_w, p_w = signal.welch(x, fs=fs, nperseg=min(q.size, 1 << 14))
            n0 = res * res / (6.0 * fs)
            w = np.clip(1.0 - n0 / np.maximum(p_w, 1e-300), 0.0, 1.0)
            X = np.fft.rfft(x)
            fr = np.fft.rfftfreq(x.size, 1.0 / fs)
            qs = np.fft.irfft(X * np.interp(fr, f_w, w), n=x.size) + (q - x)
            fc = float(f_w[np.flatnonzero(w > 0.5).max()]) if np.any(w > 0.5) else 0.0
        else:
            qs = None
            hi = prep.cutoff_hz
            lo = hi / 1000.0
            if removed(hi) >= target:
                fc = hi
            else:
                for _ in range(30):
                    mid = (lo * hi) ** 0.5
                    if removed(mid) > target:
                        lo = mid
                    else:
                        hi = mid
                fc = hi
        if qs is None:
            qs = smooth(fc)
        dq = np.gradient(qs, prep.dt_s)
        out = np.gradient(dq, prep.dt_s)[F.N_BORDER:]
        if out.size != prep.ddq.size:
            out = None
        prep.__dict__["iv_cutoff_hz"] = fc
    _IV_CACHE[key] = (prep, out)
    return out


_orig_design_full = F.design_full


def design_full(prep, spec, q=None, dq=None, ddq=None, t=None):
    names, X = _orig_design_full(prep, spec, q=q, dq=dq, ddq=ddq, t=t)
    if not os.environ.get("IV") or ddq is not None:
        return names, X
    z = iv_acceleration(prep)
    if z is None or z.size != X.shape[0]:
        return names, X
    return names + ["__iv"], np.column_stack([X, z])


_orig_solve = F._solve


def _solve(X, y, names=None):
    if names is None or names[-1] != "__iv":
        return _orig_solve(X, y, names)
    Xm = X[:, :-1]
    Z = np.column_stack([X[:, -1], X[:, 1:-1]])
    g, *_ = np.linalg.lstsq(Z, X[:, 0], rcond=None)
    Xh = Xm.copy()
    Xh[:, 0] = Z @ g
    coef, *_ = np.linalg.lstsq(Xh, y, rcond=None)
    lo = np.array([0.0 if n in F.NONNEGATIVE else -np.inf for n in names[:-1]])
    if np.any(coef < lo):
        coef = optimize.lsq_linear(Xh, y, bounds=(lo, np.full(lo.size, np.inf)), method="bvls").x
    return np.r_[coef, 0.0], y - Xm @ coef


F.design_full = design_full
F._solve = _solve
L._solve = _solve
