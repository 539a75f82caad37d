"""Least-squares fit of the plant's inverse dynamic model, with optional effects.

The procedure is the EMPS benchmark's IDIM-LS (Janot, Gautier & Brunot 2019, reference Matlab
script of the benchmark), generalised:

1. The measured position is low-pass filtered with a zero-phase 4th-order Butterworth filter
   (cut-off ``cutoff_hz``, default ``fs/10`` — 100 Hz at EMPS's 1 kHz) and differentiated twice
   by central differences (``numpy.gradient``) to give velocity and acceleration.
2. The first ``n_border = 49`` samples are dropped (filter/difference edge effects). Outside the
   EMPS benchmark, decimated samples at standstill are dropped as well (see :func:`prepare`).
3. The regressor columns (``ddq``, ``dq``, ``sign(dq)``, ``1`` and any effect columns) are built at
   the full rate and every column *and* the measured torque are decimated in parallel by
   ``decimate`` (default 10: an order-8 Chebyshev-I low-pass at 0.8 of the new Nyquist frequency,
   zero phase, then every 10th sample, ending on the last one as Matlab's ``decimate`` does).
4. Ordinary least squares on the decimated system. The relative error is
   ``100·‖y − ŷ‖/‖y‖`` over the decimated samples (the benchmark's definition).

Parameter uncertainties are ``σ̂·sqrt(diag((AᵀA)⁻¹))`` with ``σ̂`` the residual standard deviation
(the benchmark's formula). Caveat: this assumes white residuals; the residuals of a drive model are
strongly autocorrelated, so these figures are too small. :class:`FitResult` also gives
``std_eff``, inflated by ``sqrt(n/n_eff)`` with the AR(1) effective sample size
``n_eff = n(1−ρ1)/(1+ρ1)`` — still an approximation.

Model (load-side torque the drive must supply, all terms at the axis)::

    T = J·ddq + Fv·w + Fc·c + offset + (Ts − Fc)·c·exp(−(|w|/vs)²) + Σ additive effects

with ``w = dq`` and ``c = sign(dq)`` in the baseline. Effects change this as follows:
``asymmetric_friction`` splits ``w`` and ``c`` into their positive and negative parts (and drops
the offset, which the two Coulomb levels then absorb — it is not separately identifiable);
``presliding`` replaces ``c`` by the normalised LuGre bristle force ``s`` (ds/dt = k(w − |w|s),
``k = σ0/Fc``) and adds ``σ1·(w − |w|s)``; ``backlash`` computes ``w`` and ``c`` from the
play-operator output of the position (the load moves only once the gap is closed);
``position_periodic``, ``gravity_imbalance`` and ``time_periodic`` add sine/cosine column pairs.
Nonlinear hyper-parameters (vs, k, backlash width, periods, frequencies) are refined by
minimising the residual sum of squares with the linear parameters solved inside (variable
projection).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy import optimize, signal

from plant.calibration.io import Record

__all__ = ["Prepared", "ModelSpec", "FitResult", "prepare", "fit_model", "predict", "effective_n"]

N_BORDER = 49


@dataclasses.dataclass
class Prepared:
    """A record made ready for the fit (full-rate filtered signals plus the decimation).

    Attributes
    ----------
    t, q, dq, ddq, y : ndarray, shape (N,)
        Full-rate time [s], filtered position, velocity, acceleration, measured torque, after
        dropping the border.
    dt_s : float
    decim : int
    t_dec, q_dec, dq_dec, y_dec : ndarray, shape (M,)
        The decimated versions.
    record : Record
    """

    record: Record
    t: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    ddq: np.ndarray
    y: np.ndarray
    dt_s: float
    decim: int
    cutoff_hz: float
    t_dec: np.ndarray
    q_dec: np.ndarray
    dq_dec: np.ndarray
    y_dec: np.ndarray
    keep: np.ndarray | None = None
    n_standstill: int = 0
    position_resolution: float = 0.0

    def dec(self, x: np.ndarray) -> np.ndarray:
        """Decimate full-rate column(s) (axis 0) like Matlab ``decimate`` (IIR, zero phase) and keep
        the rows used by the fit (standstill rows dropped, see :func:`prepare`)."""
        out = _decimate(x, self.decim)
        return out if self.keep is None else out[self.keep]


def _decimate(x: np.ndarray, r: int) -> np.ndarray:
    if r <= 1:
        return np.asarray(x, float)
    b, a = signal.cheby1(8, 0.05, 0.8 / r)
    xf = signal.filtfilt(b, a, x, axis=0, padtype="odd", padlen=3 * (max(len(a), len(b)) - 1))
    nd = xf.shape[0]
    nout = math.ceil(nd / r)
    nbeg = r - (r * nout - nd)  # Matlab: y = odata(nbeg:r:nd), 1-based
    return xf[nbeg - 1 :: r]


def prepare(
    record: Record,
    cutoff_hz: float | None = None,
    decimate: int = 10,
    n_border: int = N_BORDER,
    exclude_standstill: bool | None = None,
    standstill_frac: float = 0.02,
) -> Prepared:
    """Filter, differentiate and set up the decimation for a record.

    Parameters
    ----------
    record : Record
    cutoff_hz : float, optional
        Butterworth cut-off [Hz]; default ``fs/10`` (EMPS: 100 Hz, the benchmark's ``5*20``).
    decimate : int
        Parallel decimation factor (EMPS benchmark: ``round(0.8·fnyq/40 Hz) = 10``).
    n_border : int
        Samples dropped at the start (benchmark: 49).
    exclude_standstill : bool, optional
        Drop decimated samples at rest (``|dq| < standstill_frac × 95th-percentile speed``): at
        rest the friction can be anything between the static limits, so ``sign(dq)`` of a
        noise-level velocity is meaningless there. Default: True, except for EMPS records, where
        the benchmark procedure (all samples) is reproduced.

    Raises
    ------
    ValueError
        Cut-off above the Nyquist frequency or a record too short.
    """
    dt = record.dt_s
    fs = 1.0 / dt
    if cutoff_hz is None:
        cutoff_hz = fs / 10.0
    if not 0 < cutoff_hz < fs / 2:
        raise ValueError(f"cutoff_hz={cutoff_hz} must lie between 0 and the Nyquist frequency {fs / 2:g} Hz")
    if len(record) < n_border + 20 * decimate:
        raise ValueError(f"record {record.name!r} too short ({len(record)} samples)")
    b, a = signal.butter(4, cutoff_hz / (fs / 2))
    qf = signal.filtfilt(b, a, record.position, padtype="odd", padlen=3 * (max(len(a), len(b)) - 1))
    dq = np.gradient(qf, dt)
    ddq = np.gradient(dq, dt)
    sl = slice(n_border, None)
    t, q, dq, ddq, y = record.t_s[sl], qf[sl], dq[sl], ddq[sl], record.torque[sl]
    t_dec, q_dec, dq_dec, y_dec = (_decimate(x, decimate) for x in (t, q, dq, y))
    if exclude_standstill is None:
        exclude_standstill = record.extra.get("format") != "emps"
    keep = None
    n_still = 0
    if exclude_standstill:
        v95 = float(np.percentile(np.abs(dq_dec), 95))
        mask = np.abs(dq_dec) >= standstill_frac * v95
        n_still = int((~mask).sum())
        if n_still:
            keep = np.flatnonzero(mask)
            t_dec, q_dec, dq_dec, y_dec = t_dec[keep], q_dec[keep], dq_dec[keep], y_dec[keep]
    steps = np.abs(np.diff(record.position))
    steps = steps[steps > 1e-12 * max(float(np.ptp(record.position)), 1e-300)]
    resolution = float(steps.min()) if steps.size else 0.0
    return Prepared(
        record=record, t=t, q=q, dq=dq, ddq=ddq, y=y, dt_s=dt, decim=decimate, cutoff_hz=cutoff_hz,
        t_dec=t_dec, q_dec=q_dec, dq_dec=dq_dec, y_dec=y_dec, keep=keep, n_standstill=n_still,
        position_resolution=resolution,
    )


@dataclasses.dataclass
class ModelSpec:
    """Which terms the model has, with the nonlinear hyper-parameters.

    Attributes
    ----------
    stribeck_vs : float or None
        Stribeck velocity [rad/s or m/s]; None: no Stribeck term.
    asymmetric : bool
        Direction-dependent viscous and Coulomb friction.
    presliding_k : float or None
        LuGre ``σ0/Fc`` [1/rad or 1/m]; None: plain ``sign``.
    backlash_width : float or None
        Play width [rad or m].
    position_periods : list of float
        Periods [rad or m] of ``position_periodic`` terms.
    gravity : bool
        ``gravity_imbalance`` term (period 2π rad).
    time_frequencies : list of float
        Frequencies [Hz] of ``time_periodic`` terms.
    """

    stribeck_vs: float | None = None
    asymmetric: bool = False
    presliding_k: float | None = None
    backlash_width: float | None = None
    position_periods: list[float] = dataclasses.field(default_factory=list)
    gravity: bool = False
    time_frequencies: list[float] = dataclasses.field(default_factory=list)

    def copy(self) -> "ModelSpec":
        return dataclasses.replace(
            self, position_periods=list(self.position_periods), time_frequencies=list(self.time_frequencies)
        )

    # hyper-parameter vector (log space, all positive) -----------------------------------------
    def hyper(self) -> list[tuple[str, int | None, float]]:
        out: list[tuple[str, int | None, float]] = []
        if self.stribeck_vs is not None:
            out.append(("stribeck_vs", None, self.stribeck_vs))
        if self.presliding_k is not None:
            out.append(("presliding_k", None, self.presliding_k))
        if self.backlash_width is not None:
            out.append(("backlash_width", None, self.backlash_width))
        for i, p in enumerate(self.position_periods):
            out.append(("position_periods", i, p))
        for i, f in enumerate(self.time_frequencies):
            out.append(("time_frequencies", i, f))
        return out

    def with_hyper(self, values: np.ndarray) -> "ModelSpec":
        s = self.copy()
        for (name, idx, _), v in zip(self.hyper(), values):
            if idx is None:
                setattr(s, name, float(v))
            else:
                getattr(s, name)[idx] = float(v)
        return s

    def n_hyper(self) -> int:
        return len(self.hyper())


def presliding_state(w: np.ndarray, k: float, dt: float) -> np.ndarray:
    """Normalised LuGre bristle force ``s`` (−1..1): ``ds/dt = k(w − |w|s)``, exact per sample.

    Parameters
    ----------
    w : ndarray
        Velocity [rad/s or m/s].
    k : float
        ``σ0/Fc`` [1/rad or 1/m].
    dt : float
        Sample period [s].
    """
    decay = np.exp(-k * np.abs(w) * dt)
    target = np.sign(w)
    s = np.empty_like(w)
    cur = float(target[0]) if w.size else 0.0
    dl = decay.tolist()
    tl = target.tolist()
    out = [0.0] * len(dl)
    for i in range(len(dl)):
        cur = tl[i] + (cur - tl[i]) * dl[i]
        out[i] = cur
    s[:] = out
    return s


def play_operator(q: np.ndarray, width: float) -> np.ndarray:
    """Backlash (play) output: the load position that follows ``q`` once the gap ``width`` is closed."""
    h = 0.5 * width
    ql = q.tolist()
    y = ql[0]
    out = [0.0] * len(ql)
    for i, x in enumerate(ql):
        if x - y > h:
            y = x - h
        elif x - y < -h:
            y = x + h
        out[i] = y
    return np.asarray(out)


def design_full(prep: Prepared, spec: ModelSpec, q=None, dq=None, ddq=None, t=None) -> tuple[list[str], np.ndarray]:
    """Full-rate regressor columns for ``spec`` (names, array of shape (N, p))."""
    q = prep.q if q is None else q
    dq = prep.dq if dq is None else dq
    ddq = prep.ddq if ddq is None else ddq
    t = prep.t if t is None else t
    dt = prep.dt_s
    if spec.backlash_width is not None:
        ql = play_operator(q, spec.backlash_width)
        w = np.gradient(ql, dt)
    else:
        w = dq
    names: list[str] = ["inertia"]
    cols: list[np.ndarray] = [ddq]
    if spec.presliding_k is not None:
        c = presliding_state(w, spec.presliding_k, dt)
    else:
        c = np.sign(w)
    if spec.asymmetric:
        names += ["viscous_pos", "viscous_neg", "coulomb_pos", "coulomb_neg"]
        cols += [np.maximum(w, 0.0), np.minimum(w, 0.0), np.maximum(c, 0.0), np.minimum(c, 0.0)]
    else:
        names += ["viscous", "coulomb"]
        cols += [w, c]
    if not spec.asymmetric:
        # With direction-dependent Coulomb levels the offset is not identifiable (the velocity is
        # almost never exactly zero, so max(c,0) − min(c,0) = 1 = the offset column): it is
        # absorbed, coulomb_pos = Fc + offset, coulomb_neg = Fc − offset.
        names.append("offset")
        cols.append(np.ones_like(w))
    if spec.stribeck_vs is not None:
        names.append("stribeck")
        cols.append(c * np.exp(-((w / spec.stribeck_vs) ** 2)))
    if spec.presliding_k is not None:
        names.append("presliding_damping")
        cols.append(w - np.abs(w) * c)
    for i, p in enumerate(spec.position_periods):
        x = 2 * np.pi * q / p
        names += [f"pos{i}_sin", f"pos{i}_cos"]
        cols += [np.sin(x), np.cos(x)]
    if spec.gravity:
        names += ["grav_sin", "grav_cos"]
        cols += [np.sin(q), np.cos(q)]
    for i, f in enumerate(spec.time_frequencies):
        x = 2 * np.pi * f * t
        names += [f"time{i}_sin", f"time{i}_cos"]
        cols += [np.sin(x), np.cos(x)]
    return names, np.column_stack(cols)


def design(prep: Prepared, spec: ModelSpec) -> tuple[list[str], np.ndarray]:
    """Decimated regressor (names, array of shape (M, p))."""
    names, X = design_full(prep, spec)
    return names, prep.dec(X)


def effective_n(resid: np.ndarray) -> float:
    """AR(1) effective sample size ``n(1−ρ1)/(1+ρ1)`` (at least 10, at most n)."""
    r = resid - resid.mean()
    den = float(np.dot(r, r))
    if den <= 0 or r.size < 3:
        return float(r.size)
    rho = float(np.dot(r[1:], r[:-1]) / den)
    rho = min(max(rho, 0.0), 0.999)
    return float(max(10.0, r.size * (1 - rho) / (1 + rho)))


@dataclasses.dataclass
class FitResult:
    """Outcome of one least-squares fit.

    Attributes
    ----------
    spec : ModelSpec
        With refined hyper-parameters.
    names : list of str
    coef, std, std_eff : ndarray
        Linear parameters, their LS standard deviations (white-residual formula) and the
        autocorrelation-inflated ones.
    residual : ndarray
        Decimated residual ``y − ŷ``.
    rss, rms, relative_error_pct : float
    n, n_eff : float
    n_params : int
        Linear plus hyper-parameters.
    """

    spec: ModelSpec
    names: list[str]
    coef: np.ndarray
    std: np.ndarray
    std_eff: np.ndarray
    residual: np.ndarray
    yhat: np.ndarray
    rss: float
    rms: float
    relative_error_pct: float
    n: int
    n_eff: float
    n_params: int

    def param(self, name: str) -> float:
        return float(self.coef[self.names.index(name)])

    def params(self) -> dict[str, float]:
        return {n: float(c) for n, c in zip(self.names, self.coef)}


def _solve(X: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    return coef, y - X @ coef


def _rss_for(prep: Prepared, spec: ModelSpec) -> float:
    try:
        _, X = design(prep, spec)
    except (FloatingPointError, ValueError):
        return float("inf")
    _, r = _solve(X, prep.y_dec)
    return float(r @ r)


def refine_hyper(
    prep: Prepared,
    spec: ModelSpec,
    rel_bounds: float | dict[int, float] = 0.3,
    free: list[int] | None = None,
    maxiter: int = 200,
) -> ModelSpec:
    """Refine the nonlinear hyper-parameters (log space, bounded) by minimising the RSS.

    Parameters
    ----------
    rel_bounds : float or dict
        Allowed relative change of each hyper-parameter (log-space half-width ``log1p(rel)``),
        per hyper-parameter index if a dict (default 0.3).
    free : list of int, optional
        Indices (into ``spec.hyper()``) to refine; the others stay fixed. Default: all.

    Notes
    -----
    One free parameter: bounded scalar minimisation; several: Nelder–Mead (bounds by an infinite
    penalty). The linear parameters are solved inside each evaluation (variable projection).
    """
    h = spec.hyper()
    if not h:
        return spec
    free = list(range(len(h))) if free is None else list(free)
    if not free:
        return spec
    full0 = np.log([v for *_, v in h])
    x0 = full0[free]
    widths = np.array(
        [math.log1p(rel_bounds.get(i, 0.3) if isinstance(rel_bounds, dict) else rel_bounds) for i in free]
    )

    def f(x: np.ndarray) -> float:
        if np.any(np.abs(x - x0) > widths + 1e-12):
            return float("inf")
        full = full0.copy()
        full[free] = x
        return _rss_for(prep, spec.with_hyper(np.exp(full)))

    f0 = f(x0)
    if len(free) == 1:
        res = optimize.minimize_scalar(
            lambda z: f(np.array([z])), bounds=(x0[0] - widths[0], x0[0] + widths[0]), method="bounded",
            options={"xatol": 1e-6, "maxiter": maxiter},
        )
        best = np.array([res.x]) if res.fun <= f0 else x0
    else:
        simplex = [x0] + [x0 + np.eye(len(x0))[i] * widths[i] * 0.3 for i in range(len(x0))]
        res = optimize.minimize(
            f, x0, method="Nelder-Mead",
            options={"initial_simplex": np.array(simplex), "xatol": 1e-6, "fatol": 1e-10 * max(f0, 1e-300), "maxiter": maxiter},
        )
        best = res.x if res.fun <= f0 else x0
    full = full0.copy()
    full[free] = best
    return spec.with_hyper(np.exp(full))


def fit_model(
    prep: Prepared,
    spec: ModelSpec,
    refine: bool = True,
    rel_bounds: float | dict[int, float] = 0.3,
    free: list[int] | None = None,
) -> FitResult:
    """Fit ``spec`` to a prepared record (hyper-parameters refined first if ``refine``; see
    :func:`refine_hyper` for ``rel_bounds`` and ``free``)."""
    if refine and spec.n_hyper():
        spec = refine_hyper(prep, spec, rel_bounds=rel_bounds, free=free)
    names, X = design(prep, spec)
    y = prep.y_dec
    coef, r = _solve(X, y)
    n, p = X.shape
    rss = float(r @ r)
    dof = max(n - p, 1)
    sigma = math.sqrt(rss / dof)
    try:
        cov = np.linalg.inv(X.T @ X)
        std = sigma * np.sqrt(np.clip(np.diag(cov), 0, None))
    except np.linalg.LinAlgError:
        std = np.full(p, np.nan)
    n_eff = effective_n(r)
    return FitResult(
        spec=spec, names=names, coef=coef, std=std, std_eff=std * math.sqrt(n / n_eff), residual=r,
        yhat=y - r, rss=rss, rms=math.sqrt(rss / n), relative_error_pct=100.0 * math.sqrt(rss) / float(np.linalg.norm(y)),
        n=n, n_eff=n_eff, n_params=p + spec.n_hyper(),
    )


def predict(prep: Prepared, fit: FitResult, refit_phases: bool = True, return_coef: bool = False):
    """Evaluate a fitted model on another prepared record (held-out validation).

    All parameters are taken from ``fit`` except, if ``refit_phases``, the *phases* of
    position- and time-periodic terms, which are record-specific (their origin is arbitrary):
    each phase is chosen to minimise the residual with the amplitude kept fixed.

    Returns
    -------
    yhat, residual : ndarray
        Decimated prediction and residual (and the coefficients used, if ``return_coef``).
    """
    names, X = design(prep, fit.spec)
    coef = fit.coef.copy()
    y = prep.y_dec
    if refit_phases:
        base = X @ coef
        for i, nm in enumerate(names):
            if not nm.endswith("_sin") or nm.startswith("grav"):
                continue
            a, b = coef[i], coef[i + 1]
            amp = math.hypot(a, b)
            if amp == 0:
                continue
            other = base - X[:, i] * a - X[:, i + 1] * b
            target = y - other
            # best phase for A sin(x+φ) = A cos φ sin x + A sin φ cos x
            s, c = X[:, i], X[:, i + 1]
            phis = np.linspace(-np.pi, np.pi, 721)
            errs = [np.sum((target - amp * (np.cos(ph) * s + np.sin(ph) * c)) ** 2) for ph in phis]
            ph = phis[int(np.argmin(errs))]
            coef[i], coef[i + 1] = amp * np.cos(ph), amp * np.sin(ph)
            base = other + X[:, i] * coef[i] + X[:, i + 1] * coef[i + 1]
    yhat = X @ coef
    if return_coef:
        return yhat, y - yhat, coef
    return yhat, y - yhat
