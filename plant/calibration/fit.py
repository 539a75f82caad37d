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
import functools
import math

import numpy as np
from scipy import optimize, signal

from plant.calibration.io import Record

__all__ = ["Prepared", "ModelSpec", "FitResult", "prepare", "filter_reach", "fit_model", "predict", "effective_n"]

N_BORDER = 49
#: Records longer than this are reduced before the fit (see :func:`prepare`).
MAX_FULL_RATE = 250_000
#: At most this many decimated samples enter the fit (long records: a coarser decimation).
MAX_FIT_SAMPLES = 60_000


#: Harmonics of a periodic motion's fundamental in the ``"phase_function"`` nuisance (assumed: the
#: smooth stand-ins documented on periodic records — gravity, a line at the motion's own frequency
#: — live in the first three; gravity over a 180° travel, ``sin(A sin φ)`` with ``A = π/2``, has
#: > 99 % of its power in harmonics 1–3, Bessel ``J1..J3``; docs/calibration.md, session 18). It is
#: the floor: a motion whose velocity needs more harmonics gets more (``ModelSpec.phase_harmonics``,
#: :func:`plant.calibration.loop.motion_harmonics`, session 25).
PHASE_HARMONICS = 3


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
    rest_mask : ndarray, shape (N,), or None
        1 where the full-rate samples enter the decimation, 0 at rest (grown by the position
        filter's reach); set only at a band coarser than the standard one (:func:`prepare`).
    coulomb : ndarray, shape (N,), or None
        The baseline's Coulomb column: ``sign(dq)``, ramped across the full-rate samples at rest by
        the standstill rule of :func:`prepare` (:func:`stick_ramp`); None when standstill samples
        are kept (EMPS), where it is ``sign(dq)``.
    hunting : list of (float, float)
        Start and end [s] of the stretches left out as hunting (:func:`hunting_mask`); empty when
        none or when standstill samples are kept.
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
    coulomb: np.ndarray | None = None
    rest_mask: np.ndarray | None = None
    hunting: list[tuple[float, float]] = dataclasses.field(default_factory=list)

    def dec(self, x: np.ndarray) -> np.ndarray:
        """Decimate full-rate column(s) (axis 0) like Matlab ``decimate`` (IIR, zero phase) and keep
        the rows used by the fit (standstill rows dropped, see :func:`prepare`)."""
        if self.rest_mask is not None:
            x = x * (self.rest_mask if x.ndim == 1 else self.rest_mask[:, None])
        out = _decimate(x, self.decim)
        return out if self.keep is None else out[self.keep]


def _decimate(x: np.ndarray, r: int) -> np.ndarray:
    """Matlab's ``decimate`` (order-8 Chebyshev I, 0.05 dB ripple, cut-off 0.8·Nyquist/r, zero phase
    by ``filtfilt``, every r-th sample ending on the last), with the filter normalised to unit DC gain.

    An even-order Chebyshev I has its DC gain at the bottom of the ripple, 10^(−0.05/20) = 0.99426,
    and ``filtfilt`` squares it: without the normalisation every decimated signal is 1.145 % low at
    low frequency. For the torque against the model's columns that cancels; for the position
    (spectra, travel, a long record's pre-decimation against its torque) it does not (session 19,
    issue 7). The time base is sampled, never filtered: :func:`_decimate_times`.
    """
    if r <= 1:
        return np.asarray(x, float)
    b, a = _decimation_filter(r)
    x = np.asarray(x, float)
    # filtered along contiguous rows (each column of a 2-D x as one row of its transpose): the
    # same arithmetic per sample as along axis 0, bit for bit, and twice as fast (session 30)
    xf = signal.filtfilt(b, a, np.ascontiguousarray(x.T), axis=-1, padtype="odd",
                         padlen=3 * (max(len(a), len(b)) - 1)).T
    return xf[_decimation_start(xf.shape[0], r) :: r]


#: Cut-off of :func:`_decimate`'s filter as a fraction of the decimated Nyquist frequency (Matlab's ``decimate``).
DECIMATION_CUTOFF = 0.8


@functools.lru_cache(maxsize=8)
def _decimation_filter(r: int) -> tuple[np.ndarray, np.ndarray]:
    """The order-8 Chebyshev I of :func:`_decimate` for factor ``r`` (b, a), unit DC gain."""
    b, a = signal.cheby1(8, 0.05, DECIMATION_CUTOFF / r)
    return b * (a.sum() / b.sum()), a


def _decimation_start(nd: int, r: int) -> int:
    """0-based index of the first kept row of ``nd`` rows decimated by ``r``: every r-th row ending on
    the last one (Matlab: ``y = odata(nbeg:r:nd)``, 1-based, ``nbeg = r − (r·ceil(nd/r) − nd)``)."""
    return r - (r * math.ceil(nd / r) - nd) - 1


def _decimate_times(t: np.ndarray, r: int) -> np.ndarray:
    """The rows of ``t`` that :func:`_decimate` keeps, unfiltered: time is the axis, not a signal
    (filtered, it came out 1.145 % short and every time-spectrum line 1.16 % high, before session 19)."""
    t = np.asarray(t, float)
    if r <= 1:
        return t
    return t[_decimation_start(t.shape[0], r) :: r]


#: The standstill rule's threshold as a fraction of the 95th-percentile speed (:func:`prepare`; also
#: the moving runs of :func:`plant.calibration.residuals.reversal_dwell_swings`). Assumed, not fitted:
#: the value the loop has used since it first left rests out of the fit; one place since session 45.
STANDSTILL_FRAC = 0.02


def prepare(
    record: Record,
    cutoff_hz: float | None = None,
    decimate: int | None = None,
    n_border: int = N_BORDER,
    exclude_standstill: bool | None = None,
    standstill_frac: float = STANDSTILL_FRAC,
    exclude_hunting: bool = True,
) -> Prepared:
    """Filter, differentiate and set up the decimation for a record.

    Parameters
    ----------
    record : Record
    cutoff_hz : float, optional
        Butterworth cut-off [Hz]; default ``fs/10`` (EMPS: 100 Hz, the benchmark's ``5*20``).
    decimate : int, optional
        Parallel decimation factor; default ``round(fs/100 Hz)`` so that the fit sees ≈ 100 Hz
        whatever the logging rate (EMPS at 1 kHz: 10, the benchmark's ``round(0.8·fnyq/40 Hz)``),
        and at least so much that no more than :data:`MAX_FIT_SAMPLES` samples enter the fit.

    Notes
    -----
    Long records (more than :data:`MAX_FULL_RATE` samples, e.g. an hour at 1 kHz) are first
    reduced by an integer factor to at most that many samples (zero-phase order-8 Chebyshev-I
    low-pass on torque and position, then every r-th sample): the effect columns are then built
    at that rate instead of the logging rate. This bounds memory and time (issue 7: 10⁶ samples in
    ≤ 1 GB); the position resolution is taken from the raw record first.
    n_border : int
        Samples dropped at the start (benchmark: 49).
    exclude_standstill : bool, optional
        Drop decimated samples at rest (``|dq| < standstill_frac × 95th-percentile speed``): at
        rest the friction can be anything between the static limits, so ``sign(dq)`` of a
        noise-level velocity is meaningless there. Default: True, except for EMPS records, where
        the benchmark procedure (all samples) is reproduced. When the decimation is coarser than
        the standard ``round(fs/100 Hz)`` (the sample cap of a long record), the torque and every
        column are also set to 0 at rest, grown by the position filter's reach
        (:func:`filter_reach`), before the decimation filter (``Prepared.rest_mask``), and the
        decimated samples there are dropped: the error at rest would otherwise spread over the
        coarse filter's reach into the moving samples (docs/calibration.md, "Session 28").
    exclude_hunting : bool
        With ``exclude_standstill``, also drop the decimated samples on stretches where the
        velocity loop hunts in stick-slip at one commanded speed (:func:`hunting_mask`; listed in
        ``Prepared.hunting`` and in the loop's log). Default True (session 44).

    Raises
    ------
    ValueError
        Cut-off above the Nyquist frequency or a record too short.
    """
    steps = np.abs(np.diff(record.position))
    steps = steps[steps > 1e-12 * max(float(np.ptp(record.position)), 1e-300)]
    resolution = float(steps.min()) if steps.size else 0.0
    del steps
    if len(record) > MAX_FULL_RATE:
        r0 = math.ceil(len(record) / MAX_FULL_RATE)
        record = dataclasses.replace(
            record, t_s=_decimate_times(record.t_s, r0).copy(),
            position=_decimate(record.position, r0).copy(), torque=_decimate(record.torque, r0).copy(),
            velocity=None, current_a=None, extra={**record.extra, "pre_decimation": r0},
        )
        n = min(record.t_s.size, record.position.size, record.torque.size)
        record.t_s, record.position, record.torque = record.t_s[-n:], record.position[-n:], record.torque[-n:]
    dt = record.dt_s
    fs = 1.0 / dt
    if decimate is None and record.extra.get("format") == "sensor_log":
        # the emulator's 100 Hz sensor log: torque from currents across compliant, backlashed gear
        # trains; fit band 4 Hz as before (tests/test_calibration_closed_loop.py)
        decimate = 10
    standard_decimate = max(1, int(round(fs / 100.0)))
    if decimate is None:
        decimate = max(standard_decimate, math.ceil((len(record) - n_border) / MAX_FIT_SAMPLES))
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
    t_dec = _decimate_times(t, decimate)
    q_dec, dq_dec, y_dec = (_decimate(x, decimate) for x in (q, dq, y))
    if exclude_standstill is None:
        exclude_standstill = record.extra.get("format") != "emps"
    keep = None
    n_still = 0
    coulomb = None
    rest_mask = None
    hunting: list[tuple[float, float]] = []
    if exclude_standstill:
        v_still = standstill_frac * float(np.percentile(np.abs(dq_dec), 95))
        rest = np.abs(dq) < v_still
        coulomb = stick_ramp(np.sign(dq), rest)
        mask = np.abs(dq_dec) >= v_still
        if decimate > standard_decimate:
            # A band coarser than the standard ≈ 100 Hz fit (the sample cap of a long record):
            # torque and columns are masked alike at rest (docs/calibration.md, "Session 28").
            # There the model is wrong by up to ±Fs, and the decimation filter spreads that error
            # over its reach (≈ 4.5·decimate samples) into the moving samples the fit keeps; at
            # a 10 Hz fit that is 0.45 s after every stop. The rest is grown by the position
            # filter's reach, over which the velocity and acceleration columns still see the stop.
            # At the standard band the loop's rules were built with the leakage present, and the
            # mask there lost as many records as it gained (session 28, bar 1): not applied.
            reach = filter_reach(b, a)
            moving = np.convolve(rest.astype(float), np.ones(2 * reach + 1), mode="same") < 0.5
            rest_mask = moving.astype(float)
            y_dec = _decimate(y * rest_mask, decimate)
            mask &= moving[_decimation_start(moving.size, decimate)::decimate]
        if exclude_hunting:
            # stick-slip stretches left out like rests (hunting_mask, session 44)
            hunt = hunting_mask(t_dec, dq_dec, v_still, resolution)
            if hunt.any():
                mask &= ~hunt
                hunting = [(float(t_dec[a]), float(t_dec[b - 1])) for a, b in true_runs(hunt)]
        n_still = int((~mask).sum())
        if n_still:
            keep = np.flatnonzero(mask)
            t_dec, q_dec, dq_dec, y_dec = t_dec[keep], q_dec[keep], dq_dec[keep], y_dec[keep]
    return Prepared(
        record=record, t=t, q=q, dq=dq, ddq=ddq, y=y, dt_s=dt, decim=decimate, cutoff_hz=cutoff_hz,
        t_dec=t_dec, q_dec=q_dec, dq_dec=dq_dec, y_dec=y_dec, keep=keep, n_standstill=n_still,
        position_resolution=resolution, coulomb=coulomb, rest_mask=rest_mask, hunting=hunting,
    )


#: Hunting detector (:func:`hunting_mask`, session 44). The numbers are assumed, none fitted: the
#: window holds several stick-slip cycles of the slow stairs seen on both generators (0.2–1 s) and is
#: a sixth of the blind generator's staircase plateaus (12–14 s); the smoothing averages a stick-slip cycle into its
#: commanded speed and still tells a speed step; "more than half the speed" is session 43's hunting
#: definition (velocity std > 0.5 × commanded speed), where a plateau's measured spread is bimodal
#: (< 0.3 or > 0.5 on the blind staircases of 13660–13899); one speed is one within a factor 2 over
#: the window; a stick is a velocity under a quarter of the speed on a fifth of the window, which
#: white Gaussian velocity noise of any rms reaches on at most 12.1 % of the samples (at rms ≈ the
#: speed: Φ(−0.75) − Φ(−1.25)); motion is a travel of 20 position quanta over the window.
HUNTING_WINDOW_S = 2.0
HUNTING_SMOOTH_S = 1.0
HUNTING_SPREAD_MIN = 0.5
HUNTING_CONST_RATIO = 0.5
HUNTING_STICK_SPEED = 0.25
HUNTING_STICK_SHARE = 0.2
HUNTING_MIN_QUANTA = 20


def hunting_mask(t: np.ndarray, w: np.ndarray, v_still: float, resolution: float = 0.0) -> np.ndarray:
    """Samples on stretches where the axis sticks and slips (the velocity loop hunts) at one
    commanded speed.

    A sample is on such a stretch when a window of :data:`HUNTING_WINDOW_S` around it (or around a
    sample within half a window) shows

    1. one speed: the velocity averaged over :data:`HUNTING_SMOOTH_S` keeps its sign and stays
       within a factor 1/:data:`HUNTING_CONST_RATIO`;
    2. motion: that speed carries the axis over :data:`HUNTING_MIN_QUANTA` position quanta in the
       window (above ``v_still`` when the position is not quantised) — a slow stair whose samples
       are mostly at rest still counts, its slip bursts are what the fit would see;
    3. spread: the velocity's part faster than the averaging has an rms above
       :data:`HUNTING_SPREAD_MIN` × the speed;
    4. sticking: the velocity stays under :data:`HUNTING_STICK_SPEED` × the speed on at least
       :data:`HUNTING_STICK_SHARE` of the window (noise alone, or a ripple that does not stop the
       axis, does not hunt).

    Why (session 44, docs/calibration.md): on a slow stair below the Stribeck velocity the axis
    sticks and slips. The torque of a slip burst follows the friction's dynamics at breakaway
    (bristle state, frictional lag, the drive's spring), which neither the baseline nor a library
    kind holds, and the fit spends effects on it — on the blind generator's staircases a pre-sliding
    named for a residual spread over the whole record (session 43: baseline residual mostly on such
    plateaus → 7 of 8 records wrong, 5 with a false pre-sliding). The stretches are left out of the
    fit like a rest, where the friction is equally undetermined.

    Parameters
    ----------
    t : ndarray, shape (M,)
        Evenly spaced decimated times [s] (before any sample is dropped).
    w : ndarray, shape (M,)
        Decimated velocity [rad/s or m/s].
    v_still : float
        Standstill threshold [same unit as ``w``] (:func:`prepare`).
    resolution : float
        Position quantum [rad or m] (``Prepared.position_resolution``); 0 if not quantised.

    Returns
    -------
    ndarray of bool, shape (M,)
        True on hunting stretches.
    """
    from scipy.ndimage import maximum_filter1d, minimum_filter1d, uniform_filter1d
    if t.size < 10:
        return np.zeros(t.size, bool)
    dt = float(np.median(np.diff(t)))
    ns = max(3, int(round(HUNTING_SMOOTH_S / dt)) | 1)
    nw = max(5, int(round(HUNTING_WINDOW_S / dt)) | 1)
    if nw > t.size:
        return np.zeros(t.size, bool)
    sm = uniform_filter1d(w, ns, mode="nearest")
    speed = np.abs(uniform_filter1d(sm, nw, mode="nearest"))
    rms = np.sqrt(np.maximum(uniform_filter1d((w - sm) ** 2, nw, mode="nearest"), 0.0))
    smax = maximum_filter1d(sm, nw, mode="nearest")
    smin = minimum_filter1d(sm, nw, mode="nearest")
    one_speed = (smin * smax > 0) & (np.minimum(np.abs(smin), np.abs(smax))
                                     >= HUNTING_CONST_RATIO * np.maximum(np.abs(smin), np.abs(smax)))
    v_move = HUNTING_MIN_QUANTA * resolution / HUNTING_WINDOW_S if resolution > 0 else v_still
    # the stick share against each window's own speed: the share of |w| < c·speed_i over window i
    # equals the window's mean of 1[|w_j| < c·speed_i]; evaluated on the candidate windows only
    centre = one_speed & (speed > v_move) & (rms > HUNTING_SPREAD_MIN * speed)
    half = nw // 2
    for i in np.flatnonzero(centre):
        seg = w[max(0, i - half): i + half + 1]
        if np.mean(np.abs(seg) < HUNTING_STICK_SPEED * speed[i]) < HUNTING_STICK_SHARE:
            centre[i] = False
    return maximum_filter1d(centre.astype(np.uint8), nw, mode="constant").astype(bool)


def filter_reach(b: np.ndarray, a: np.ndarray, energy: float = 0.999) -> int:
    """Half-width of a zero-phase (``filtfilt``) filter's impulse response.

    Parameters
    ----------
    b, a : ndarray
        The filter's coefficients (one pass).
    energy : float
        Share of the impulse response's energy the half-width must hold (default 99.9 %, session 6's
        definition: 13 samples for the order-4 Butterworth at ``fs/10``).

    Returns
    -------
    int
        Half-width [samples]: the samples ``c−k … c+k`` around the impulse hold ``energy`` of it.
    """
    n = 2001
    x = np.zeros(n)
    x[n // 2] = 1.0
    h = signal.filtfilt(b, a, x) ** 2
    c = n // 2
    tot = h.sum()
    for k in range(c):
        if h[c - k:c + k + 1].sum() >= energy * tot:
            return k
    return c


@dataclasses.dataclass
class ModelSpec:
    """Which terms the model has, with the nonlinear hyper-parameters.

    Attributes
    ----------
    stribeck_vs : float or None
        Stribeck velocity [rad/s or m/s]; None: no Stribeck term.
    asymmetric : bool
        Direction-dependent viscous and Coulomb friction.
    coulomb_split : bool
        Direction-dependent Coulomb friction with a symmetric viscous term (ignored when
        ``asymmetric``). With the offset absorbed, this is the offset acting only while the axis
        moves; used as the twin an ``asymmetric_friction`` candidate must beat
        (:func:`plant.calibration.loop._viscous_split_predicts`), never as an effect.
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
    gear_stiffness : float or None
        The drive's stiffness between the logged position and the load, *declared* by the engineer
        (``--gear-stiffness``) [N·m/rad or N/m]; not fitted.
    spring_coulomb : float or None
        The Coulomb level [N·m or N] that sets the declared spring's swing ``2·spring_coulomb /
        gear_stiffness`` (the current fit's, :func:`plant.calibration.loop._beats_gear_spring`). With
        both set (and no pre-sliding), friction acts through the spring: :func:`geared_coulomb`.
    """

    stribeck_vs: float | None = None
    asymmetric: bool = False
    coulomb_split: bool = False
    presliding_k: float | None = None
    backlash_width: float | None = None
    position_periods: list[float] = dataclasses.field(default_factory=list)
    gravity: bool = False
    time_frequencies: list[float] = dataclasses.field(default_factory=list)
    nuisance: list[str] = dataclasses.field(default_factory=list)
    #   out-of-library descriptions kept in the working model so that library effects can still be
    #   found on top of them (never written to the plant file): "friction_drift" (Coulomb and
    #   viscous terms times τ and τ², τ = normalised time), "delay" (the jerk column: a shift of the
    #   torque against the motion, to first order), "velocity_function" (piecewise-linear in |dq| per
    #   direction, used only to test whether a time line is a velocity-dependent error),
    #   "friction_along_travel" (the Coulomb column times hinges in the position at its 5-95 %
    #   quantiles: a friction level that varies along the travel, used only to test whether a time
    #   line is such a friction, session 39),
    #   "phase_function" (sin, cos of k·2π·phase_hz·t, k = 1..phase_harmonics: any smooth function of
    #   a periodic motion's phase, used only to test whether a smooth term stands in for the model's
    #   own error on a periodic trajectory, loop.periodic_motion_hz; with ``phase_odd`` the odd k only:
    #   the error of a model symmetric in the motion on a half-wave symmetric motion, loop.half_wave_fundamental)
    #: fundamental [Hz] of a periodic motion, for the ``"phase_function"`` nuisance
    phase_hz: float | None = None
    #: harmonics of ``phase_hz`` in the ``"phase_function"`` nuisance: as many as the motion's velocity
    #: needs (loop.motion_harmonics), at least :data:`PHASE_HARMONICS`
    phase_harmonics: int = PHASE_HARMONICS
    #: only the odd harmonics k = 1, 3, … ≤ ``phase_harmonics`` in the ``"phase_function"`` nuisance (a
    #: half-wave symmetric motion: loop.half_wave_fundamental, session 42)
    phase_odd: bool = False
    #: shape of the ``"friction_drift"`` nuisance's second time column: ``None`` for τ² (sessions ≤ 47),
    #: else ``exp(−τ/λ)`` with this λ, the drift's time constant as a fraction of the record (a
    #: first-order warm-up; chosen by :func:`plant.calibration.loop._drift_candidate`, session 48)
    drift_time_constant: float | None = None
    #: the ``"friction_drift"`` nuisance as a heating: its columns are the Coulomb and viscous
    #: columns times first-order lags (time constant ``drift_time_constant``) of ``|dq|`` and
    #: ``dq²``, the two parts of the friction power — a friction level that follows a temperature
    #: warmed by the friction's own dissipation, not the clock (:func:`heating_shapes`, session 49)
    drift_heating: bool = False
    gear_stiffness: float | None = None
    spring_coulomb: float | None = None

    @property
    def geared(self) -> bool:
        """Friction acts through the declared gear spring (:func:`geared_coulomb`)."""
        return self.gear_stiffness is not None and self.spring_coulomb is not None and self.presliding_k is None

    def copy(self) -> "ModelSpec":
        return dataclasses.replace(
            self, position_periods=list(self.position_periods), time_frequencies=list(self.time_frequencies),
            nuisance=list(self.nuisance),
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


def _presliding_kernel(decay: np.ndarray, target: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    out = np.empty(decay.size)
    cur = target[0] if decay.size else 0.0
    for i in range(decay.size):
        cur = target[i] + (cur - target[i]) * decay[i]
        out[i] = cur
    return out


def _play_kernel(q: np.ndarray, h: float) -> np.ndarray:  # pragma: no cover - compiled
    out = np.empty(q.size)
    y = q[0] if q.size else 0.0
    for i in range(q.size):
        x = q[i]
        if x - y > h:
            y = x - h
        elif x - y < -h:
            y = x + h
        out[i] = y
    return out


try:  # the two sample-by-sample recursions compiled when numba is there (same code interpreted otherwise)
    from numba import njit as _njit

    _presliding_kernel = _njit(cache=True)(_presliding_kernel)
    _play_kernel = _njit(cache=True)(_play_kernel)
except ImportError:  # pragma: no cover
    pass


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
    w = np.ascontiguousarray(w, dtype=float)
    return _presliding_kernel(np.exp(-k * np.abs(w) * dt), np.sign(w))


def play_operator(q: np.ndarray, width: float) -> np.ndarray:
    """Backlash (play) output: the load position that follows ``q`` once the gap ``width`` is closed."""
    return _play_kernel(np.ascontiguousarray(q, dtype=float), 0.5 * float(width))


def geared_coulomb(q: np.ndarray, gap: float, swing: float) -> tuple[np.ndarray, np.ndarray]:
    """Friction seen through a compliant gear, with an optional gap in it: (load position, Coulomb column).

    The position ``q`` is logged on the motor side of a gear spring of stiffness ``K``; the load
    behind it carries Coulomb friction ``Fc`` and sticks until the spring transmits ``Fc``. After a
    reversal the spring first unwinds (``Fc/K`` of motor travel), the gap is crossed (``gap``), and
    the spring winds up the other way (``Fc/K``), so the transmitted friction torque swings from
    ``−Fc`` to ``+Fc`` over ``gap + 2Fc/K``. The load position is the play output
    ``q_l = play(q, gap + 2·swing)`` with ``swing = Fc/K``; the column is the spring's torque over
    ``Fc``, ``s = dz(q − q_l, gap/2) / swing`` in [−1, 1], ``dz`` the dead zone. ``gap = 0`` is the
    elasto-plastic (Prandtl stop) operator. The load's inertia is not modelled (the motion is
    slow at a reversal). Docs: docs/calibration.md, "Session 20".

    Parameters
    ----------
    q : ndarray, shape (N,)
        Motor-side position [rad or m].
    gap : float
        Full width of the gap [rad or m], ≥ 0.
    swing : float
        ``Fc/K`` [rad or m], > 0.

    Returns
    -------
    (ndarray, ndarray)
        Load position [rad or m] and the Coulomb column (dimensionless), shape (N,) each.
    """
    h = 0.5 * float(gap)
    ql = play_operator(q, 2.0 * (h + float(swing)))
    delta = np.asarray(q, dtype=float) - ql
    return ql, np.where(delta > h, delta - h, np.where(delta < -h, delta + h, 0.0)) / float(swing)


def true_runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """The runs of True in a boolean array of shape (N,), as ``(start, stop)`` index pairs (stop
    exclusive), in order. Used by :func:`stick_ramp` (rests), :func:`prepare` (hunting stretches) and
    :func:`plant.calibration.residuals.reversal_dwell_swings` (moving runs)."""
    edges = np.flatnonzero(np.diff(np.r_[0, np.asarray(mask, dtype=bool).astype(np.int8), 0]))
    return [(int(a), int(b)) for a, b in zip(edges[0::2], edges[1::2])]


def stick_ramp(c: np.ndarray, rest: np.ndarray) -> np.ndarray:
    """The Coulomb column ``c = sign(w)`` with each run of rest samples replaced by a straight line
    from the sliding value before the run to the one after it.

    While the axis sticks, the friction balances whatever torque is applied, and a servo loop
    changes that torque continuously (a PI integrator ramps it through the static band at a
    reversal). ``sign`` of a velocity at noise level flips from sample to sample instead: an error
    of ±Fc at the rate of the samples, which the decimation filter spreads as ringing into the
    moving samples beside the rest (docs/calibration.md, "Session 6"), where reversal effects
    (pre-sliding, backlash) took it as evidence. The decimated rest samples are not fitted in any
    case; this makes the error they leak smooth. Shapes: (N,) each; returns a new array.
    """
    out = np.array(c, dtype=float)
    n = out.size
    for a, b in true_runs(rest):
        left = out[a - 1] if a > 0 else (out[b] if b < n else 0.0)
        right = out[b] if b < n else left
        out[a:b] = left + (right - left) * (np.arange(1, b - a + 1) / (b - a + 1))
    return out


def design_full(prep: Prepared, spec: ModelSpec, q=None, dq=None, ddq=None, t=None) -> tuple[list[str], np.ndarray]:
    """Full-rate regressor columns for ``spec`` (names, array of shape (N, p))."""
    names, cols = design_columns(prep, spec, q, dq, ddq, t)
    return names, np.column_stack(cols)


def design_columns(prep: Prepared, spec: ModelSpec, q=None, dq=None, ddq=None,
                   t=None) -> tuple[list[str], list[np.ndarray]]:
    """Full-rate regressor columns for ``spec``: names and a list of p arrays of shape (N,), float64.

    The columns of :func:`design_full` before they are stacked: :func:`design` hashes and decimates
    them one by one, and a stacked (N, p) copy of a long record's columns cost more than the fit
    (session 30, docs/calibration.md "Hour-long logs").
    """
    q = prep.q if q is None else q
    dq = prep.dq if dq is None else dq
    ddq = prep.ddq if ddq is None else ddq
    t = prep.t if t is None else t
    dt = prep.dt_s
    geared = None
    if spec.geared:
        ql, geared = geared_coulomb(q, spec.backlash_width or 0.0, spec.spring_coulomb / spec.gear_stiffness)
        w = np.gradient(ql, dt)
    elif spec.backlash_width is not None:
        ql = play_operator(q, spec.backlash_width)
        w = np.gradient(ql, dt)
    else:
        w = dq
    names: list[str] = ["inertia"]
    cols: list[np.ndarray] = [ddq]
    if geared is not None:
        c = geared
    elif spec.presliding_k is not None:
        c = presliding_state(w, spec.presliding_k, dt)
    else:
        use_ramp = prep.coulomb is not None and spec.backlash_width is None and dq is prep.dq
        c = prep.coulomb if use_ramp else np.sign(w)
    split = spec.asymmetric or spec.coulomb_split
    if spec.asymmetric:
        names += ["viscous_pos", "viscous_neg", "coulomb_pos", "coulomb_neg"]
        cols += [np.maximum(w, 0.0), np.minimum(w, 0.0), np.maximum(c, 0.0), np.minimum(c, 0.0)]
    elif spec.coulomb_split:
        names += ["viscous", "coulomb_pos", "coulomb_neg"]
        cols += [w, np.maximum(c, 0.0), np.minimum(c, 0.0)]
    else:
        names += ["viscous", "coulomb"]
        cols += [w, c]
    if not split:
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
    for nz in spec.nuisance:
        if nz == "friction_drift":
            tau = (t - t[0]) / max(float(t[-1] - t[0]), 1e-12)
            names += ["nz_drift_c1", "nz_drift_w1", "nz_drift_c2", "nz_drift_w2"]
            if spec.drift_heating:
                if spec.drift_time_constant is None:
                    raise ValueError("the heating friction drift needs ModelSpec.drift_time_constant")
                h1, h2 = heating_shapes(w, dt, spec.drift_time_constant * max(float(t[-1] - t[0]), 1e-12))
                cols += [c * h1, w * h1, c * h2, w * h2]
            else:
                shape = drift_shape(tau, spec.drift_time_constant)
                cols += [c * tau, w * tau, c * shape, w * shape]
        elif nz == "friction_along_travel":
            # the Coulomb column times a piecewise-linear function of the position (hinges at the
            # 5-95 % quantiles): a friction level that changes along the travel (bearing load with
            # the axis attitude, seal or cable drag), direction-odd as friction is; session 39
            knots = np.quantile(q, [0.05, 0.25, 0.5, 0.75, 0.95])
            for j, kn in enumerate(knots):
                names.append(f"nz_travel{j}")
                cols.append(c * np.maximum(q - kn, 0.0))
        elif nz == "delay":
            names.append("nz_delay_jerk")
            cols.append(np.gradient(ddq, dt))
        elif nz == "velocity_function":
            a = np.abs(w)
            knots = np.quantile(a, [0.05, 0.25, 0.5, 0.75, 0.95])
            for j, kn in enumerate(knots):
                hinge = np.maximum(a - kn, 0.0)
                names += [f"nz_vel{j}_pos", f"nz_vel{j}_neg"]
                cols += [hinge * (w > 0), hinge * (w < 0)]
        elif nz == "phase_function":
            if spec.phase_hz is None:
                raise ValueError("the phase_function nuisance needs ModelSpec.phase_hz")
            for k in range(1, max(int(spec.phase_harmonics), PHASE_HARMONICS) + 1, 2 if spec.phase_odd else 1):
                x = 2 * np.pi * k * spec.phase_hz * t
                names += [f"nz_phase{k}_sin", f"nz_phase{k}_cos"]
                cols += [np.sin(x), np.cos(x)]
    return names, [np.ascontiguousarray(c, dtype=np.float64) for c in cols]


def drift_shape(tau: np.ndarray, time_constant: float | None) -> np.ndarray:
    """The friction drift's second time function on normalised time ``tau`` (0..1, shape (N,)):
    ``τ²`` when ``time_constant`` is None, else ``exp(−τ/time_constant)`` (a first-order warm-up
    whose time constant is that fraction of the record). With the Coulomb column and ``τ`` in the
    model, ``exp(−τ/λ)`` tends to the span of ``τ²`` as λ grows, so the quadratic is the limit of
    a slow warm-up (session 48)."""
    if time_constant is None:
        return tau**2
    return np.exp(-tau / time_constant)


def heating_shapes(w: np.ndarray, dt_s: float, time_constant_s: float) -> tuple[np.ndarray, np.ndarray]:
    """First-order lags of the two parts of the friction power, each scaled to mean 1 over the record.

    A friction level that follows a temperature warmed by the friction's own dissipation
    (``P = Fc·|w| + Fv·w²``) and cooled toward ambient with one time constant changes by
    ``β·(Fc·x₁ + Fv·x₂)``, ``xᵢ`` the lags of ``|w|`` and ``w²`` from a cold start: linear in the two
    lags, so the drift is fitted as the Coulomb and viscous columns times each (session 49).

    Parameters
    ----------
    w : ndarray, shape (N,)
        Velocity [rad/s or m/s], uniformly sampled.
    dt_s : float
        Sample interval [s].
    time_constant_s : float
        The heating's time constant [s] (> 0).

    Returns
    -------
    x1, x2 : ndarray, shape (N,)
        Lags of ``|w|`` and ``w²``, each divided by its mean (mean 1; zeros for a record at rest).
    """
    a = math.exp(-dt_s / time_constant_s)
    out = []
    for u in (np.abs(w), w * w):
        x = signal.lfilter([1.0 - a], [1.0, -a], u)
        m = float(np.mean(x))
        out.append(x / m if m > 0 else np.zeros_like(x))
    return out[0], out[1]


def drift_shape_mean(time_constant: float | None) -> float:
    """Mean of :func:`drift_shape` over τ uniform on 0..1: 1/3, or ``λ(1 − e^(−1/λ))``."""
    if time_constant is None:
        return 1.0 / 3.0
    return time_constant * (1.0 - math.exp(-1.0 / time_constant))


def design(prep: Prepared, spec: ModelSpec) -> tuple[list[str], np.ndarray]:
    """Decimated regressor (names, array of shape (M, p)).

    Decimated columns are cached on ``prep`` by the content of the full-rate column: the loop
    evaluates hundreds of specs that differ in one column, and the zero-phase decimation filter is
    the costly part.
    """
    names, cols = design_columns(prep, spec)
    cache = prep.__dict__.setdefault("_dec_cache", {})
    if len(cache) * prep.y_dec.size * 8 > 64 * 2**20:  # at most ≈ 64 MB of cached columns
        cache.clear()
    keys = [(name, hash(col.tobytes())) for name, col in zip(names, cols)]
    for key, col in zip(keys, cols):
        if key not in cache:
            cache[key] = prep.dec(col)
    return names, np.column_stack([cache[k] for k in keys])


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


#: Linear parameters that are physically non-negative: fitted with these bounds (not rejected after
#: the fact). Inertia, viscous and Coulomb friction (each direction), the LuGre bristle damping σ1, the Stribeck excess Ts − Fc.
NONNEGATIVE = ("inertia", "viscous", "coulomb", "viscous_pos", "viscous_neg", "coulomb_pos", "coulomb_neg",
               "presliding_damping", "stribeck")


def _solve(X: np.ndarray, y: np.ndarray, names: list[str] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Least squares with the :data:`NONNEGATIVE` parameters bounded at 0 (``scipy.optimize.lsq_linear``,
    bounded-variable least squares; plain ``lstsq`` when its solution is already feasible)."""
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    if names is not None:
        lo = np.array([0.0 if n in NONNEGATIVE else -np.inf for n in names])
        if np.any(coef < lo):
            sol = optimize.lsq_linear(X, y, bounds=(lo, np.full(len(names), np.inf)), method="bvls")
            coef = sol.x
    return coef, y - X @ coef


def _resid_for(prep: Prepared, spec: ModelSpec) -> np.ndarray | None:
    try:
        names, X = design(prep, spec)
    except (FloatingPointError, ValueError):
        return None
    _, r = _solve(X, prep.y_dec, names)
    return r


def _rss_for(prep: Prepared, spec: ModelSpec) -> float:
    r = _resid_for(prep, spec)
    return float("inf") if r is None else float(r @ r)


def refine_hyper(
    prep: Prepared,
    spec: ModelSpec,
    rel_bounds: float | dict[int, float] = 0.3,
    free: list[int] | None = None,
    maxiter: int = 40,
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
    Bounded nonlinear least squares (``scipy.optimize.least_squares``, trust-region reflective) on
    the residual vector, in log space scaled to the allowed window (``u ∈ [−1, 1]``), so every
    hyper-parameter stays positive and within its physical window; the linear parameters are
    solved inside each evaluation with their own bounds (variable projection). With one free
    parameter a 7-point scan of the window gives the start (the RSS of a period or a width can
    have local minima).
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
    m = prep.y_dec.size

    def spec_at(u: np.ndarray) -> ModelSpec:
        full = full0.copy()
        full[free] = x0 + np.clip(u, -1.0, 1.0) * widths
        return spec.with_hyper(np.exp(full))

    def fun(u: np.ndarray) -> np.ndarray:
        r = _resid_for(prep, spec_at(u))
        return np.full(m, 1e150 ** 0.5 / max(m, 1)) if r is None else r

    u0 = np.zeros(len(free))
    if len(free) == 1:
        scan = np.linspace(-1.0, 1.0, 7)
        rss = [float(np.sum(fun(np.array([v])) ** 2)) for v in scan]
        u0 = np.array([scan[int(np.argmin(rss))]])
    r0 = fun(u0)
    try:
        sol = optimize.least_squares(fun, u0, bounds=(-np.ones(len(free)), np.ones(len(free))), method="trf",
                                     diff_step=1e-4, x_scale=1.0, max_nfev=maxiter, xtol=1e-6, ftol=1e-8)
        best = sol.x if float(sol.fun @ sol.fun) <= float(r0 @ r0) else u0
    except ValueError:
        best = u0
    return spec_at(best)


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
    coef, r = _solve(X, y, names)
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


#: Out-of-library descriptions (and their columns) that describe the *machine* (its drive and
#: measurement chain) and so hold on any record of it: the delay between torque and motion (the jerk
#: column; EMPS: ≈ 0.3 ms, the current loop's lag behind its reference, which is what EMPS logs as
#: force). A held-out record is predicted with them. The other descriptions describe the *record*
#: and are dropped on another one: the friction drift is a function of the record's own normalised
#: time, the velocity function's knots are quantiles of the record's speeds.
TRANSFERABLE_NUISANCE = {"delay": ("nz_delay_jerk",)}
TRANSFERABLE_COLUMNS = tuple(c for cols in TRANSFERABLE_NUISANCE.values() for c in cols)


def predict(prep: Prepared, fit: FitResult, refit_phases: bool = True, return_coef: bool = False,
            library_only: bool = False):
    """Evaluate a fitted model on another prepared record (held-out validation).

    All parameters are taken from ``fit`` except, if ``refit_phases``, the *phases* of
    position- and time-periodic terms, which are record-specific (their origin is arbitrary):
    each phase is chosen to minimise the residual with the amplitude kept fixed. Out-of-library
    descriptions of the record are dropped; those of the machine (:data:`TRANSFERABLE_COLUMNS`) are
    kept unless ``library_only`` (the model the calibrated plant file can carry).

    Returns
    -------
    yhat, residual : ndarray
        Decimated prediction and residual (and the coefficients used, if ``return_coef``).
    """
    names, X = design(prep, fit.spec)
    coef = fit.coef.copy()
    for i, nm in enumerate(names):
        if nm.startswith("nz_") and (library_only or nm not in TRANSFERABLE_COLUMNS):
            coef[i] = 0.0
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
