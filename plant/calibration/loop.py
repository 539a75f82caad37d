"""The calibration loop: baseline fit, then greedy selection of effects that predict unseen data.

Algorithm
---------
1. **Baseline**: inertia, viscous, Coulomb, offset (the benchmark's IDIM-LS model). The LuGre static
   Stribeck term (``Ts − Fc ≥ 0``, ``vs``) is added only if it passes the same predictive test as an
   effect and at least 2 % of the moving samples lie below ``2·vs`` (see :func:`fit_baseline`).
2. **Candidates**, one builder per kind of the :mod:`plant.effects` registry (:data:`KINDS` is that
   registry; an import-time check makes sure every registered kind has a builder): asymmetric
   friction where the axis moves both ways (≥ :data:`MIN_SAMPLES_PER_DIRECTION` moving samples on
   each side); pre-sliding (LuGre bristle state) and backlash (play operator), which compete for the
   residual at reversals; position-periodic terms at the strongest peaks of the residual's position
   spectrum with ≥ 2 cycles over the travel, and time-periodic terms at the strongest peaks of its
   time spectrum with ≥ 2 cycles in the record, their period/frequency refined by the fit within
   the peak's width; gravity imbalance whenever the travel spans ≥ :data:`GRAVITY_MIN_SPAN_RAD`.
   All are fitted with physical bounds (friction, σ1, Ts − Fc ≥ 0 via bounded linear least squares;
   widths, periods, σ0/Fc > 0 and inside their window via ``scipy.optimize.least_squares``).
   Out-of-library descriptions compete too: a **friction drift** over the record (a first-order
   warm-up with its time constant fitted, or a quadratic in time where that predicts no better;
   session 48) and a **torque-to-motion delay**.
3. **Acceptance — prediction of data the fit did not see.** The decimated record is cut into
   ``k_folds`` contiguous time blocks; each block is predicted by the model fitted on the others,
   for the current model and for the current model plus the candidate (hyper-parameters as refined
   on the whole record). The per-sample reduction of the squared prediction error is averaged over
   40 contiguous batches and tested with Wilcoxon's signed-rank test (:func:`cv_compare`; one of
   the tests Diebold & Mariano 1995 give for equal predictive accuracy) at a family-wise error
   ``family_alpha`` = 1 % over every candidate test the run may make (Bonferroni,
   :func:`z_critical`); with ``--validate`` the held-out record's rms must fall too. A library
   candidate must also predict at least ``min_share_pct`` (3 %) of the held-out error, the share
   from which the report lists structure at all (:func:`_below_share_floor`, session 51: on tens of
   thousands of samples a sliver of the model's own error passes the rank test). Of the
   candidates that pass, the one with the largest predictive gain is taken (the others of that
   step are its competitors, written to the report with their gains); an out-of-library
   description wins only if it predicts significantly better than the best library candidate. A
   time-periodic candidate at a frequency where the motion itself has a line must pass the test
   again with a flexible velocity function in both models (so a velocity-dependent model error
   cannot pass as a disturbance). On a periodic motion (:func:`periodic_motion_hz`: K harmonics of
   one fundamental explain ≥ ``PERIODIC_MIN_SHARE`` of the velocity, ≥ 3 cycles, K the smallest
   number from ``PHASE_HARMONICS`` to ``PERIODIC_MAX_HARMONICS`` that does: a sinusoid needs 3, a
   back-and-forth sweep's square-ish velocity up to 9) a
   gravity, position-periodic or time-periodic candidate must pass the test again with those
   K harmonics in both models (the phase guard: position, velocity, acceleration and the motion's
   own lines are then functions of one phase, and a smooth term can stand in for the model's
   error along it); on a half-wave symmetric motion (:func:`half_wave_fundamental`) the guard holds
   only the motion's odd harmonics, the only lines the error of a model symmetric in the motion
   can have, and the library candidates that pass compete on their gain beyond them (session 42);
   a time-periodic candidate within one frequency bin (``1/T``, the record's
   Rayleigh resolution) of one of those K harmonics is refused outright — on a half-wave
   symmetric motion of one of its odd harmonics only; near an even one it goes on to the guard's
   test and the competition (session 56). Transitions (pre-sliding
   displacement, backlash width) under :data:`MIN_TRANSITION_COUNTS` position quanta are not
   resolved and not added, nor are time or position lines whose amplitude, as the inertial torque
   of a motion, is a displacement under that many quanta (:func:`_line_resolved`). A candidate whose
   fit drives a positive inertia to its bound 0 stands in for the inertia and is refused
   (:func:`_replaces_inertia`). While the current model has no Stribeck term, a pre-sliding or
   backlash candidate must pass the test again with that term in both models
   (:func:`_beats_stribeck`: near every reversal the velocity crosses the Stribeck region).
4. **Out-of-library structure**: a winning out-of-library description is kept in the working model
   (so library effects can still be found on top) but never written to the plant file; it and any
   spectral peak still standing (share ≥ ``min_share_pct``, false-alarm probability
   < 1e-3) are reported in ``unexplained`` with their domain and share.

Why these levels: 1 % family-wise is a conventional strict level; the Bonferroni count makes it
hold over the whole greedy search (≈ 12 candidates × 5 steps → z ≥ 3.6), not per test. Neither is
tuned on a generator (docs/calibration.md).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Callable

import numpy as np
from scipy import linalg, optimize, stats

from plant.calibration import residuals as res
from plant.calibration.fit import (DECIMATION_CUTOFF, PHASE_HARMONICS, TRANSFERABLE_NUISANCE, FitResult, ModelSpec, Prepared, _solve, design, drift_shape_mean,
                                    effective_n, fit_model, predict)
from plant.effects import EFFECT_KINDS, Effect, build_effect

__all__ = ["LoopConfig", "AcceptedEffect", "LoopResult", "fit_baseline", "run_loop", "delta_bic", "cv_compare", "min_events",
           "KINDS", "backlash_gap", "check_stiffness", "friction_levels", "periodic_motion_hz", "periodic_motion",
           "motion_harmonics", "PERIODIC_MAX_HARMONICS", "UNDECIDED_REVERSALS", "UNDECIDED_PERIODIC",
           "rank_batches", "rank_batches_needed", "GEOMETRY_RULES", "unit_compare", "reversal_units", "MIN_UNITS"]

#: The effect kinds the loop may name: exactly the :mod:`plant.effects` registry.
KINDS: tuple[str, ...] = tuple(EFFECT_KINDS)
#: The reversal effects: they compete for the residual at velocity reversals (one of them at most).
REVERSAL_KINDS = frozenset({"presliding", "backlash"})
#: Out-of-library descriptions that compete with the library (kept in the working model only).
OUT_OF_LIBRARY = ("friction_drift", "delay")
#: Out-of-library descriptions of the machine, not of the record (see
#: :data:`plant.calibration.fit.TRANSFERABLE_COLUMNS`): with a held-out record they must lower its
#: rms, as a library effect must, and they stay in its prediction.
TRANSFERABLE = tuple(TRANSFERABLE_NUISANCE)
#: Terms that a periodic motion's phase function can stand in for (the phase guard of :func:`run_loop`):
#: the smooth terms (session 18) and the reversal kinds, whose state on a periodic motion is a function of
#: its phase too (session 21, docs/calibration.md).
PHASE_GUARDED = frozenset({"gravity_imbalance", "position_periodic", "time_periodic", "presliding", "backlash"})
#: Gravity imbalance is tried when the travel spans at least this much [rad] (20°): below it
#: ``sin θ``, ``cos θ`` are nearly collinear with the offset (cos) and a position-linear torque
#: (sin), and amplitude and phase trade off against each other.
GRAVITY_MIN_SPAN_RAD = math.radians(20.0)


@dataclasses.dataclass
class LoopConfig:
    """Settings of the loop (see the module docstring for their meaning)."""

    family_alpha: float = 0.01
    k_folds: int = 8
    max_effects: int = 5
    n_peaks: int = 3
    #: the smallest share of the residual [%] the loop speaks of: a spectral peak is reported in
    #: ``unexplained`` from this share, and a library effect is named only if it predicts at least
    #: this share of the held-out error (:func:`_below_share_floor`, session 51). Assumed: 3 %, the
    #: report's floor since the first version of the loop, kept when the named effects got the same one
    min_share_pct: float = 3.0
    kinds: tuple[str, ...] = KINDS
    #: known periods of the drive [rad, or m for a linear record] — a motor or worm revolution, a
    #: screw lead — declared by the user: a position line within one spectral bin of one of them
    #: is exempt from the line-resolution rule (:func:`_line_resolved`); the record alone cannot
    #: tell a line of a few quanta from the measurement chain's structure, the drive's design can
    drive_periods: tuple[float, ...] = ()
    #: the drive's stiffness between the logged position and the load [N·m/rad, or N/m], declared
    #: by the user from the drive's design (``--gear-stiffness``): a reversal effect must then also
    #: predict better than the current model with this spring in it (:func:`_beats_gear_spring`)
    gear_stiffness: float | None = None
    #: test a time line against a friction level that varies along the travel
    #: (:func:`_not_friction_along_travel`, session 39); False only to measure the test's effect
    travel_friction_guard: bool = True
    #: refuse a line at an alias of the encoder's count rate (:func:`_count_alias`, session 40); False
    #: only to measure the test's effect
    count_alias_guard: bool = True
    #: on a half-wave symmetric periodic motion the phase guard holds the odd harmonics of the
    #: motion only (:func:`half_wave_fundamental`, session 42), and a time line is refused as
    #: unresolvable only within one bin of those (session 56); False only to measure its effect
    odd_phase_guard: bool = True


@dataclasses.dataclass
class AcceptedEffect:
    kind: str
    slot: int | None  # index among position/time periodic terms
    rms_after: float
    variance_explained_pct: float
    delta_bic: float
    evidence: str
    val_rms_after: float | None = None
    cv_gain_pct: float = 0.0
    cv_z: float = 0.0
    competitors: list[dict[str, Any]] = dataclasses.field(default_factory=list)


@dataclasses.dataclass
class LoopResult:
    baseline: FitResult
    final: FitResult
    accepted: list[AcceptedEffect]
    #: candidates turned down: kind, step, gain, z, explained share, ``reason``, ``also`` (the other
    #: rules that refuse it) and ``rules`` (their names); a line (time or position periodic) also its
    #: refined ``line`` and, where another candidate of the step lies on the same line,
    #: ``same_line_as`` (:func:`_lines_described`)
    rejected: list[dict[str, Any]]
    unexplained: list[dict[str, Any]]
    stribeck: dict[str, Any]
    val_rms_before: float | None = None
    val_rms_after: float | None = None
    #: held-out rms of the library effects alone (what the calibrated plant file carries)
    val_rms_after_library: float | None = None
    val_baseline: tuple[np.ndarray, np.ndarray] | None = None
    val_final: tuple[np.ndarray, np.ndarray] | None = None
    linear: bool = False
    log: list[str] = dataclasses.field(default_factory=list)
    out_of_library: list[dict[str, Any]] = dataclasses.field(default_factory=list)
    #: effects the record cannot decide, never named: ``reason`` :data:`UNDECIDED_REVERSALS` (a reversal
    #: effect on too few reversals, :func:`min_events`: ``n_reversals``, ``min_reversals``) or
    #: :data:`UNDECIDED_PERIODIC` (refused by the phase guard after passing the rule: ``why``, and the
    #: refined ``line``); kind, step, gain, z, ``note``
    undecided: list[dict[str, Any]] = dataclasses.field(default_factory=list)

    def effects(self) -> list[Effect]:
        """The accepted effects as :mod:`plant.effects` objects, in the order they were added."""
        return [effect_from_fit(self.final, a.kind, a.slot) for a in self.accepted]


def delta_bic(rss0: float, rss1: float, dk: int, n_eff: float) -> float:
    """``n_eff·ln(RSS₁/RSS₀) + Δk·ln(n_eff)`` (reported for information; not the acceptance rule)."""
    if rss1 <= 0 or rss0 <= 0:
        return -math.inf
    return n_eff * math.log(rss1 / rss0) + dk * math.log(n_eff)


def _hyper_index(spec: ModelSpec, name: str, slot: int | None = None) -> int:
    for i, (n, idx, _) in enumerate(spec.hyper()):
        if n == name and idx == slot:
            return i
    raise KeyError(name)


class CVErrors(np.ndarray):
    """Blocked cross-validation prediction errors (an ndarray) with ``extrapolated``: a bool array of
    the same shape, True where the held-out row lies outside its training rows' regressor hull
    (:func:`hidden_extrapolation`)."""

    extrapolated: np.ndarray


def hidden_extrapolation(X_tr: np.ndarray, X_te: np.ndarray) -> np.ndarray:
    """True for each row of ``X_te`` (shape (m, p)) that is a hidden extrapolation from the rows
    ``X_tr`` (shape (n, p)) a least-squares fit was made on: its leverage ``xᵀ(X_trᵀX_tr)⁺x`` exceeds
    the largest leverage of a training row, or it has a component in the null space of ``X_tr``
    (the smallest ellipsoid around the regressor hull; Montgomery, Peck & Vining, *Introduction to
    Linear Regression Analysis*, "hidden extrapolation"). There the fitted parameters are not pinned
    by the data they were fitted on. The rank cut-off is numpy's ``lstsq``'s (``max(n, p)·eps`` of the
    largest singular value); a null-space component counts when it exceeds 10³ times that relative
    to the row's norm, which only allows for rounding (a numerical tolerance, not a threshold on
    the data). Session 33, docs/calibration.md."""
    if X_tr.size == 0 or X_te.size == 0:
        return np.zeros(X_te.shape[0], dtype=bool)
    U, sv, Vt = np.linalg.svd(X_tr, full_matrices=False)
    if sv.size == 0 or not sv[0] > 0:
        return np.ones(X_te.shape[0], dtype=bool)
    keep = sv > sv[0] * max(X_tr.shape) * np.finfo(float).eps
    h_max = float(np.max(np.sum(U[:, keep] ** 2, axis=1)))
    proj = X_te @ Vt[keep].T
    h_te = np.sum((proj / sv[keep]) ** 2, axis=1)
    out = h_te > h_max
    if not keep.all():
        resid = X_te - proj @ Vt[keep]
        scale = np.linalg.norm(X_te, axis=1)
        out |= np.linalg.norm(resid, axis=1) > 1e3 * np.finfo(float).eps * max(X_tr.shape) * np.maximum(scale, 1e-300)
    return out


def cv_losses(prep: Prepared, spec: ModelSpec, k_folds: int = 8) -> CVErrors:
    """Prediction errors of blocked cross-validation (decimated samples, time order; square them for the loss).

    Each of ``k_folds`` contiguous blocks is predicted by the linear parameters fitted (with their
    bounds) on the other blocks; hyper-parameters are those of ``spec``. The result carries
    ``extrapolated`` (:class:`CVErrors`): the held-out rows that are hidden extrapolations from their
    fold's training rows (:func:`hidden_extrapolation`; session 33).
    """
    names, X = design(prep, spec)
    return cv_losses_xy(names, X, prep.y_dec, k_folds)


def cv_losses_xy(names: list[str], X: np.ndarray, y: np.ndarray, k_folds: int = 8) -> CVErrors:
    """:func:`cv_losses` on given decimated columns ``X`` (shape (M, p), named ``names``, the
    :data:`plant.calibration.fit.NONNEGATIVE` ones bounded) and target ``y`` (shape (M,)): for
    descriptions that are not a :class:`plant.calibration.fit.ModelSpec`
    (:mod:`plant.calibration.two_mass`)."""
    n = y.size
    edges = np.linspace(0, n, k_folds + 1).astype(int)
    pred = np.empty(n)
    ext = np.zeros(n, dtype=bool)
    for a, b in zip(edges[:-1], edges[1:]):
        tr = np.r_[0:a, b:n]
        coef, _ = _solve(X[tr], y[tr], names)
        pred[a:b] = X[a:b] @ coef
        ext[a:b] = hidden_extrapolation(X[tr], X[a:b])
    err = (y - pred).view(CVErrors)
    err.extrapolated = ext
    return err


#: Fewest samples in a batch of the rank test (:func:`cv_compare`): longer than the residual's correlation.
BATCH_MIN_SAMPLES = 25


def rank_batches(n_samples: int, n_batches: int = 40) -> int:
    """Batches of :func:`cv_compare`'s rank test on ``n_samples`` compared samples: ``n_batches``, fewer
    where a batch would hold under :data:`BATCH_MIN_SAMPLES` (the test is not made below 5)."""
    return int(min(n_batches, n_samples // BATCH_MIN_SAMPLES))


def cv_compare(err0: np.ndarray, err1: np.ndarray, n_batches: int = 40,
               units: np.ndarray | None = None) -> tuple[float, float]:
    """Predictive gain of model 1 over model 0 from their CV prediction errors: (gain in % of the CV
    mean squared error, z statistic).

    ``d = err0² − err1²`` per sample, averaged over ``n_batches`` contiguous batches (at least 25
    samples each; a batch outlasts the residual's correlation, so batch means are close to
    independent). ``z`` is the normal approximation of **Wilcoxon's signed-rank statistic** of the
    batch means — the rank test Diebold & Mariano (1995) give for comparing predictive accuracy.
    Why a rank test and not ``mean/SE``: a real effect helps very unevenly (backlash at a few
    reversals, asymmetric friction mostly in one direction's segments), and the spread of such
    gains between batches inflates the standard error of a mean-based test, while the ranks see
    that the large changes are all improvements. Under the null (no better prediction) the batch
    differences are symmetric about a value ≤ 0. Samples that model 1 can only extrapolate to and
    model 0 cannot (``CVErrors.extrapolated``) are left out of both losses (session 33).

    With ``units`` (start indices of consecutive units, the first 0; :func:`reversal_units`) the rank
    test and :func:`unit_compare` (a test on the per-unit loss ratios, for a reversal effect on fewer
    counted reversals than a sign test can pass on) are both made and either may carry the decision:
    ``z`` is the normal z of ``min(1, 2·min(p_rank, p_unit))``, Bonferroni over the two (session 61: the
    t-test alone, replacing the rank test, lost records where the loop's reversal count misses slow
    stairs and the rank test does pass). The gain is the same.
    """
    # samples model 1 can only extrapolate to and model 0 cannot: model 1's extra parameters are not
    # pinned there by the rows its fold was fitted on, so neither loss counts them (session 33)
    e0 = getattr(err0, "extrapolated", None)
    e1 = getattr(err1, "extrapolated", None)
    err0, err1 = np.asarray(err0), np.asarray(err1)
    use = ~(e1 & ~e0) if (e0 is not None and e1 is not None) else np.ones(err0.size, dtype=bool)
    if units is not None:
        # either test may carry the decision: Bonferroni over the two (the smaller p, doubled)
        gain, z_rank = cv_compare(err0, err1, n_batches)
        z_unit = unit_compare(np.where(use, err0**2, 0.0), np.where(use, err1**2, 0.0), units)
        p = min(1.0, 2.0 * min(float(stats.norm.sf(z_rank)), float(stats.norm.sf(z_unit))))
        return gain, float(stats.norm.isf(p))
    err0, err1 = err0[use], err1[use]
    loss0, loss1 = err0**2, err1**2
    d = loss0 - loss1
    m0 = float(np.mean(loss0))
    B = rank_batches(d.size, n_batches)
    if m0 <= 0 or B < 5:
        return 0.0, 0.0
    edges = np.linspace(0, d.size, B + 1).astype(int)
    bm = np.add.reduceat(d, edges[:-1]) / np.diff(edges)
    nz = bm[bm != 0]
    if nz.size < 5:
        return 100.0 * float(np.mean(d)) / m0, 0.0
    n = nz.size
    ranks = stats.rankdata(np.abs(nz))
    w_plus = float(ranks[nz > 0].sum())
    z = (w_plus - n * (n + 1) / 4.0) / math.sqrt(n * (n + 1) * (2 * n + 1) / 24.0)
    return 100.0 * float(np.mean(d)) / m0, float(z)


#: Fewest units :func:`unit_compare` tests on (two degrees of freedom of Student's t; with two units
#: one ratio's spread is estimated from one other and no level of the rule can be reached anyway).
MIN_UNITS = 3


def unit_compare(loss0: np.ndarray, loss1: np.ndarray, units: np.ndarray) -> float:
    """z of the paired test of two models' held-out losses summed per unit (session 61).

    ``r_i = ln(Σ loss0 / Σ loss1)`` over each unit ``i`` (a stretch of the record holding one velocity
    reversal, :func:`reversal_units`); one-sided Student's t of their mean against 0 with ``k − 1``
    degrees of freedom, returned as the normal z of the same p-value so that it is compared with the
    run's critical z like :func:`cv_compare`'s. Why beside the rank test: a reversal effect's gain lies
    at the reversals, and ``k`` reversals that all improve give a sign-symmetric test at best
    ``p = 2⁻ᵏ`` (:func:`min_events`): on fewer than 13 no size or consistency of gain passes 1 %
    family-wise (the rank test can still pass where the gain is spread beyond the counted reversals,
    so it is kept; :func:`cv_compare` makes both). A unit's ratio is a sum over hundreds of samples around its reversal, so the ratios
    are close to normal and the t-test's level holds; the test uses how much each reversal improves
    beside how many. Under the null (the candidate does not predict better) the ratios scatter about a
    value ≤ 0. Units whose loss is 0 in either model (every sample left out as an extrapolation) are
    dropped.

    Parameters
    ----------
    loss0, loss1 : ndarray, shape (M,)
        Held-out squared errors of the current model and the candidate [(N·m)², N² on a linear record],
        0 where a sample is not compared.
    units : ndarray of int, shape (k,)
        Start index of each unit (the first 0, increasing); a unit runs to the next start.

    Returns
    -------
    float
        z (0 with fewer than :data:`MIN_UNITS` units or no spread).
    """
    starts = np.asarray(units, dtype=int)
    s0, s1 = np.add.reduceat(loss0, starts), np.add.reduceat(loss1, starts)
    ok = (s0 > 0) & (s1 > 0)
    r = np.log(s0[ok] / s1[ok])
    k = r.size
    if k < MIN_UNITS:
        return 0.0
    sd = float(np.std(r, ddof=1))
    if not sd > 0:
        return 0.0
    t = float(np.mean(r)) / (sd / math.sqrt(k))
    return float(stats.norm.isf(max(float(stats.t.sf(t, k - 1)), 1e-300)))


def reversal_units(prep: Prepared) -> np.ndarray | None:
    """Start indices (decimated samples) of one unit per velocity reversal of the record, cut halfway
    between consecutive reversals (the first unit from the record's start, the last to its end), for
    :func:`unit_compare`; the reversals are those :func:`plant.calibration.residuals.count_reversals`
    counts (session 46's cut, on the loop's own count). None with fewer than :data:`MIN_UNITS`."""
    rev = res.counted_reversals(prep.t_dec, prep.dq_dec)
    if len(rev) < MIN_UNITS:
        return None
    return np.array([0] + [(a + b) // 2 for a, b in zip(rev[:-1], rev[1:])], dtype=int)


def predicts(gain_pct: float, z: float, zc: float) -> bool:
    """The acceptance rule on a :func:`cv_compare` result: a positive gain, significant (``z ≥ zc``)."""
    return gain_pct > 0 and z >= zc


def z_critical(alpha: float, n_tests: int) -> float:
    """One-sided normal critical value for a family-wise error ``alpha`` over ``n_tests`` tests (Bonferroni)."""
    return float(stats.norm.isf(alpha / max(n_tests, 1)))


def single_test_z(cfg: "LoopConfig") -> float:
    """Critical z of a test made once per run beside the candidate steps (the Stribeck term, the friction
    drift's exponential shape): the run's family-wise level ``cfg.family_alpha`` over 12 tests per step
    times ``cfg.max_effects`` steps, the Bonferroni count the Stribeck test has used since it joined the
    family."""
    return z_critical(cfg.family_alpha, 12 * cfg.max_effects)


def min_events(alpha: float, n_tests: int) -> int:
    """Fewest independent events (batches that all improve) that can pass the rank test at all.

    With ``k`` non-zero batch gains, the most extreme outcome under the symmetric null of
    :func:`cv_compare` (all ``k`` positive) has probability ``2⁻ᵏ``, so no size of gain passes the
    one-sided level ``alpha / n_tests`` unless ``k ≥ log₂(n_tests / alpha)`` (1 % over 60 tests:
    13). A reversal effect (pre-sliding, backlash) acts mostly near the velocity reversals, so on a
    record with fewer reversals than this its gain can pass only where it also helps away from them
    (backlash on development record 1048 passed with 11), or on the reversals' own loss ratios
    (:func:`unit_compare`, which uses the gains' sizes; session 61); a refused one is reported as undecided.
    """
    return int(math.ceil(math.log2(max(n_tests, 1) / alpha)))


def rank_batches_needed(zc: float, n_batches: int = 40) -> int | None:
    """Fewest batches that must hold a gain for :func:`cv_compare`'s rank test to reach ``zc`` when the
    gain lies only there and every other batch is no better than chance (session 53).

    The ``k`` batches that hold the gain then carry the ``k`` largest ranks, all improvements, and the
    others contribute half their ranks to ``W⁺`` on average: ``z(k) = (Σ_{r=n−k+1}^{n} r + ½·Σ_{r=1}^{n−k} r
    − n(n+1)/4) / sqrt(n(n+1)(2n+1)/24)``. With 40 batches and the loop's ``zc`` ≈ 3.59 this is 17
    (z = 3.66; 16 give 3.49) — more than :func:`min_events` (13), the floor of any sign-symmetric test,
    because the batches without a reversal dilute the ranks. It is what a record needs for a reversal
    effect whose gain lies at its reversals (one reversal per batch, so spread over the record); where
    those batches lose a little, more (used independent 15124: about 24, docs/calibration.md,
    "Session 52").

    Parameters
    ----------
    zc : float
        Critical z of the test.
    n_batches : int
        Batches of the rank test (40, fewer on a short record: :func:`cv_compare`).

    Returns
    -------
    int or None
        ``k``; None when even ``n_batches`` batches do not reach ``zc``.
    """
    n = int(n_batches)
    if n < 1:
        return None
    mean, sd = n * (n + 1) / 4.0, math.sqrt(n * (n + 1) * (2 * n + 1) / 24.0)
    for k in range(1, n + 1):
        w_plus = (n * (n + 1) - (n - k) * (n - k + 1)) / 2.0 + (n - k) * (n - k + 1) / 4.0
        if (w_plus - mean) / sd >= zc:
            return k
    return None


def fit_baseline(prep: Prepared, cfg: LoopConfig | None = None) -> tuple[FitResult, dict[str, Any]]:
    """Fit the baseline; add the Stribeck term only where the data excite it.

    Criterion: the best Stribeck velocity on a log grid (0.3 %–30 % of the 95th-percentile speed),
    refined, with ``Ts − Fc ≥ 0`` as a bound, must (a) pass the blocked cross-validation test of the
    loop at the run's family-wise level and (b) have at least 2 % of the samples in motion slower than ``2·vs`` —
    otherwise the low-speed region is not sampled and ``Ts``/``vs`` would be extrapolations.
    """
    cfg = cfg or LoopConfig()
    base = fit_model(prep, ModelSpec())
    v95 = float(np.percentile(np.abs(prep.dq_dec), 95))
    decision: dict[str, Any] = {"included": False}
    if v95 <= 0:
        decision["reason"] = "no motion"
        return base, decision
    best = fit_stribeck(prep, ModelSpec())
    gain, z = cv_compare(cv_losses(prep, base.spec, cfg.k_folds), cv_losses(prep, best.spec, cfg.k_folds))
    k = best.names.index("stribeck")
    excess, sd = float(best.coef[k]), float(best.std_eff[k])
    mov = res.moving_mask(prep.dq_dec)
    slow_share = float(np.mean(np.abs(prep.dq_dec[mov]) < 2 * best.spec.stribeck_vs)) if mov.any() else 0.0
    decision.update({"vs": best.spec.stribeck_vs, "static_minus_coulomb": excess, "std_eff": sd, "cv_gain_pct": gain,
                     "cv_z": z, "slow_share": slow_share})
    # the Stribeck test belongs to the run's family of tests: same Bonferroni level as the effects
    zc = single_test_z(cfg)
    if predicts(gain, z, zc) and excess > 0 and slow_share >= 0.02:
        decision["included"] = True
        decision["reason"] = (f"predicts held-out blocks better (gain {gain:.1f} %, z = {z:.1f}), Ts − Fc = {excess:.3g} ± {sd:.2g}, "
                              f"{100 * slow_share:.1f} % of moving samples below 2·vs")
        return best, decision
    why = []
    if not predicts(gain, z, zc):
        why.append(f"cross-validated gain {gain:.2f} % with z = {z:.1f} (needs > 0 and z ≥ {zc:.2f})")
    if not excess > 0:
        why.append("Ts − Fc at its bound 0 (no static excess)")
    if slow_share < 0.02:
        why.append(f"only {100 * slow_share:.1f} % of moving samples below 2·vs")
    decision["reason"] = "; ".join(why)
    return base, decision


def fit_stribeck(prep: Prepared, spec: ModelSpec) -> FitResult:
    """``spec`` with the Stribeck term added, its velocity ``vs`` chosen on a log grid (0.3 %–30 % of
    the 95th-percentile speed, 12 points; the lowest rss) and refined within ±50 %: the search of
    :func:`fit_baseline`, also used by :func:`_beats_stribeck` on the current model."""
    v95 = float(np.percentile(np.abs(prep.dq_dec), 95))
    best = None
    for vs in v95 * np.logspace(math.log10(0.003), math.log10(0.3), 12):
        f = fit_model(prep, dataclasses.replace(spec.copy(), stribeck_vs=float(vs)), refine=False)
        if best is None or f.rss < best.rss:
            best = f
    assert best is not None
    return fit_model(prep, best.spec, rel_bounds=0.5)


def _beats_stribeck(prep: Prepared, cur: FitResult, c: dict[str, Any], zc: float, cfg: LoopConfig,
                    cache: dict[str, Any], units: np.ndarray | None = None) -> str | None:
    """None if the reversal candidate ``c`` still predicts held-out blocks better (the rule, at the
    same level ``zc``) with the Stribeck term in both the current model and the candidate, else why not.

    Near every reversal the velocity passes through the Stribeck region, so while that friction is
    missing from the model, or described with a ``vs`` that no longer fits, the reversal kinds are
    the only candidates that can take the low-speed friction error there; a real transition (a
    bristle, a dead zone) keeps its gain once that error has its best description. The term's
    ``vs`` is re-chosen on the current model (:func:`fit_stribeck`, the term taken out first),
    once per step (``cache``, one dict per step):

    - the current model has no Stribeck term (the baseline left it out: too few slow samples, or
      no significant gain on its own): the candidate is tested again with the term in both models.
      Found on clean records 8263 and 8318 (pre-sliding of 68 and 170 counts where the generator's
      is below one); docs/calibration.md, "Session 34".
    - it has one: only if the re-chosen ``vs`` lowers the current model's training rss (the
      baseline chose ``vs`` against a residual that a later effect explained), the candidate is
      tested again with that ``vs`` in both models. Found on fixed seed 23 (``vs`` 0.032 chosen
      against a 6.6 N·m time line, 0.012 once the line is in the model, the generator's 0.0115);
      docs/calibration.md, "Session 35".

    An intersection of tests at one level: it can miss an effect, it cannot add one.
    """
    if "loss" not in cache:
        s = fit_stribeck(prep, dataclasses.replace(cur.spec.copy(), stribeck_vs=None))
        if cur.spec.stribeck_vs is not None and not s.rss < cur.rss:
            cache["vs"], cache["loss"] = None, None   # the model's own vs is as good as the grid's
        else:
            cache["vs"], cache["loss"] = s.spec.stribeck_vs, cv_losses(prep, s.spec, cfg.k_folds)
    vs = cache["vs"]
    if vs is None:
        return None
    cand = fit_model(prep, dataclasses.replace(c["fit"].spec.copy(), stribeck_vs=vs))
    g, z = cv_compare(cache["loss"], cv_losses(prep, cand.spec, cfg.k_folds), units=units)
    which = ("which the current model lacks" if cur.spec.stribeck_vs is None
             else f"re-chosen on the current model, which has vs = {cur.spec.stribeck_vs:.3g}")
    c["gain_with_stribeck_pct"], c["z_with_stribeck"] = g, z
    c["stribeck_note"] = f"vs = {vs:.3g}, {which}"
    if predicts(g, z, zc):
        return None
    return (f"with the Stribeck term (vs = {vs:.3g}, {which}) in both models the candidate no "
            f"longer predicts (gain {g:.2f} %, z = {z:.1f}, needs z ≥ {zc:.2f}): the reversal residual is low-speed "
            "friction, not a transition")


MIN_TRANSITION_COUNTS = 10.0


def _below_share_floor(c: dict[str, Any], cfg: LoopConfig) -> str | None:
    """None if a library candidate predicts at least ``cfg.min_share_pct`` of the held-out error, else
    why it is refused (session 51).

    The rank test of :func:`cv_compare` asks whether a candidate predicts better on every part of
    the record, not by how much: with tens of thousands of samples a term that lowers the held-out
    error by 0.1 % lowers it in every batch, and reaches any z. A model that is not the drive's
    (LuGre against a static friction curve, a measurement chain the model lacks) leaves a residual
    with structure in every batch, and a sinusoid or a friction split can take a sliver of it on
    any record. Such a term is as likely the model's own error as a torque of its own, and a named
    effect is a stronger claim than an ``unexplained`` entry, which the report makes only from the
    same share. Both floors are ``cfg.min_share_pct``.

    Parameters
    ----------
    c : dict
        The candidate (its ``cv_gain_pct`` [%] and ``cv_z``, from :func:`_evaluate`).
    cfg : LoopConfig

    Returns
    -------
    str or None
    """
    if c["cv_gain_pct"] >= cfg.min_share_pct:
        return None
    return (f"predicts only {c['cv_gain_pct']:.2f} % of the held-out error (z = {c['cv_z']:.1f}), under "
            f"{cfg.min_share_pct:g} %, the smallest share of the residual the report speaks of: significant on this many "
            "samples, but as likely a sliver of the model's own error as a torque of its own")


def _resolved(fit: FitResult, resolution: float = 0.0) -> str | None:
    """None if the fit's transitions are resolved by the record, else why not.

    A reversal transition within a few encoder counts cannot be told from Coulomb friction that
    sticks for a moment at the reversal (the baseline's own behaviour).
    """
    if fit.spec.presliding_k is not None and 1.0 / fit.spec.presliding_k < MIN_TRANSITION_COUNTS * resolution:
        return (f"pre-sliding displacement 1/k = {1.0 / fit.spec.presliding_k:.3g} is below {MIN_TRANSITION_COUNTS:g} "
                f"position quanta ({resolution:.3g}): not resolved")
    if fit.spec.backlash_width is not None and fit.spec.backlash_width < MIN_TRANSITION_COUNTS * resolution:
        return (f"backlash width {fit.spec.backlash_width:.3g} is below {MIN_TRANSITION_COUNTS:g} position quanta "
                f"({resolution:.3g}): not resolved")
    return None


#: :func:`_sticks_at_reversals` (session 45), assumed, not fitted: a stick swings the torque through
#: the static band (``Fc + Fs ≥ 2·Fc``) at the turning point; a bristle the loop may name at all
#: (``1/k`` of at least :data:`MIN_TRANSITION_COUNTS` quanta, :func:`_resolved`) changes it within 2.5
#: quanta of the turn by at most ``2(1 − e^(−2.5/10))·Fc = 0.44·Fc``; half the Coulomb step, ``Fc``,
#: lies between. The median of at least two reversals (one can be disturbed by a line or a noise burst).
STICK_SWING_OVER_FC = 1.0
STICK_MIN_REVERSALS = 2
#: the same for a backlash (session 45, second change): the loop's gap (a play on the logged position,
#: the Coulomb column 0 while it is crossed; at least :data:`MIN_TRANSITION_COUNTS` quanta wide) changes
#: the friction at the turn by ``Fc`` (from ``±Fc`` to 0, a declared spring's unwinding included) and the
#: rest only a gap's width later; the whole Coulomb step, ``2·Fc``, at the turning point contradicts it.
STICK_SWING_OVER_FC_GAP = 2.0


def _sticks_at_reversals(fit: FitResult, swings: np.ndarray, resolution: float) -> str | None:
    """None unless a pre-sliding or backlash fit is contradicted by how the record's reversals move,
    else why. For the reversal candidates only: a later candidate's fit carries an accepted
    pre-sliding or backlash too, which is not the claim under test.

    A pre-sliding names the friction's reversal step a function of displacement: within
    :data:`plant.calibration.residuals.DWELL_QUANTA` quanta of the turning point a bristle the loop
    may name changes the friction by at most ``0.44·Fc``. Where the record's torque changes there by
    at least :data:`STICK_SWING_OVER_FC` × ``Fc`` (the candidate's Coulomb level) at the median
    reversal (:func:`plant.calibration.residuals.reversal_dwell_swings`), the axis stuck while the
    servo ramped the torque — static friction with stiff bristles, whose breakaway a bristle in the
    filtered velocity only imitates (docs/calibration.md, "Session 45"). A backlash (a gap crossed
    with no friction) changes it there by ``Fc`` at most; it is refused where the swing reaches
    :data:`STICK_SWING_OVER_FC_GAP` × ``Fc``, the whole Coulomb step. Not applied with fewer than
    :data:`STICK_MIN_REVERSALS` measured reversals.
    """
    gap = fit.spec.backlash_width is not None and fit.spec.presliding_k is None
    if (fit.spec.presliding_k is None and not gap) or swings.size < STICK_MIN_REVERSALS:
        return None
    fc = _coulomb(fit)
    med = float(np.median(swings))
    limit = STICK_SWING_OVER_FC_GAP if gap else STICK_SWING_OVER_FC
    if not fc > 0 or med < limit * fc:
        return None
    head = (f"the axis sticks at its reversals: within {res.DWELL_QUANTA} position quanta of the turning point the torque "
            f"changes by {med:.3g} (median of {swings.size} reversals), {med / fc:.2f} × the candidate's Fc = {fc:.3g}; ")
    if gap:
        return head + (f"a gap of {fit.spec.backlash_width:.3g} crossed without friction changes it there by at most Fc, the "
                       "rest a gap's width later: the whole step at a fixed position is static friction, not a gap")
    bound = 2.0 * (1.0 - math.exp(-(res.DWELL_QUANTA + 0.5) * resolution * fit.spec.presliding_k)) * fc
    return head + (f"its bristle (1/k = {1.0 / fit.spec.presliding_k:.3g}) changes it there by at most {bound:.3g}: static "
                   "friction with a stiff bristle, not pre-sliding")


def typical_speed(prep: Prepared) -> float:
    """The record's typical moving speed [rad/s or m/s]: the median ``|dq|`` of the decimated moving
    samples (:func:`plant.calibration.residuals.moving_mask`); 0 if nothing moves."""
    mov = res.moving_mask(prep.dq_dec)
    return float(np.median(np.abs(prep.dq_dec[mov]))) if mov.any() else 0.0


def line_motion_quanta(amplitude: float, inertia: float, w: float, resolution: float) -> float:
    """A torque line's amplitude as the inertial torque of a motion, in position quanta:
    ``A / (J·ω²) / q`` (see :func:`_line_resolved`).

    Parameters
    ----------
    amplitude : float
        Line amplitude ``A`` [N·m or N].
    inertia : float
        ``J`` [kg·m² or kg], > 0.
    w : float
        Angular frequency ``ω`` [rad/s], > 0.
    resolution : float
        One position quantum ``q`` [rad or m], > 0.
    """
    return amplitude / (inertia * w * w) / resolution


def _line_resolved(fit: FitResult, kind: str, slot: int, resolution: float, speed_typ: float,
                   drive_periods: tuple[float, ...] = (), span: float = 0.0) -> str | None:
    """None if a time or position line moves the axis by at least :data:`MIN_TRANSITION_COUNTS`
    position quanta, else why the record cannot resolve it.

    A torque line of amplitude ``A`` at angular frequency ``ω`` is, if it were the inertial torque
    of a motion the record does not show, a displacement ``x = A / (J·ω²)``. The position is known
    to one quantum and the velocity loop acts on the same quantised counts, so a line whose ``x``
    is within a few quanta cannot be told from the measurement chain's own structure (the loop's
    reaction to its quantised feedback, the encoder's count patterns) — the same resolution limit,
    and the same constant, as for reversal transitions (:func:`_resolved`). For a position line the
    frequency is taken at the record's typical speed: ``ω = 2π·speed_typ/period``
    (:func:`typical_speed`). Found in session 19 (docs/calibration.md): with the time axis
    corrected, lines with ``x`` ≈ 0.007–3.6 quanta were named on 10 development records that hide
    no line, while every hidden line of the development seeds has ``x`` ≥ 250 quanta.

    Parameters
    ----------
    fit : FitResult
        The candidate's fit (its ``inertia`` coefficient is ``J`` [kg·m² or kg]).
    kind : str
        ``"time_periodic"`` or ``"position_periodic"``; other kinds return None.
    slot : int
        The line's index in ``time_frequencies`` / ``position_periods``.
    resolution : float
        One position quantum [rad or m].
    speed_typ : float
        Typical moving speed [rad/s or m/s].
    drive_periods : tuple of float
        Declared periods of the drive [rad or m] (:attr:`LoopConfig.drive_periods`): a position line
        within one spectral bin of one (``|p − P| < p²/span``, one cycle over the travel) is exempt.
    span : float
        Travel of the moving samples [rad or m], for that bin.
    """
    if kind not in ("time_periodic", "position_periodic") or resolution <= 0 or "inertia" not in fit.names:
        return None
    if kind == "position_periodic" and span > 0:
        p = fit.spec.position_periods[slot]
        if any(abs(p - pd) < p * p / span for pd in drive_periods):
            return None
    j = fit.param("inertia")
    if not j > 0:
        return None
    if kind == "time_periodic":
        a, b = fit.param(f"time{slot}_sin"), fit.param(f"time{slot}_cos")
        w = 2.0 * math.pi * fit.spec.time_frequencies[slot]
        at = f"{w / (2.0 * math.pi):.4g} Hz"
    else:
        a, b = fit.param(f"pos{slot}_sin"), fit.param(f"pos{slot}_cos")
        w = 2.0 * math.pi * speed_typ / fit.spec.position_periods[slot]
        at = f"{w / (2.0 * math.pi):.4g} Hz at the typical speed {speed_typ:.3g}"
    if not w > 0:
        return None
    n_q = line_motion_quanta(math.hypot(a, b), j, w, resolution)
    if n_q < MIN_TRANSITION_COUNTS:
        return (f"the line's amplitude {math.hypot(a, b):.3g} at {at} is the inertial torque of a motion of "
                f"{n_q:.2g} position quanta (A/(J·ω²), J = {j:.4g}), below {MIN_TRANSITION_COUNTS:g}: the record "
                "cannot tell it from the measurement chain's own structure (quantised feedback in the loop)")
    return None


#: Constant-speed runs the count-alias test (:func:`_count_alias`) reads: at least this long [s]
#: (assumed: a run must resolve a line to ≤ 0.5 Hz, one Rayleigh bin ``1/d``, to be compared with an alias) ...
COUNT_ALIAS_MIN_RUN_S = 2.0
#: ... with the filtered speed within this fraction of the run's median (assumed: 2 %, the speed ripple
#: of a closed velocity loop at constant set-point; a ramp is not a run) ...
COUNT_ALIAS_SPEED_TOL = 0.02
#: ... and the harmonics ``k`` of the count rate whose aliases are compared (assumed: the quantisation
#: error of ``floor(θ/q)`` is a sawtooth in the position with harmonics falling as ``1/k``; the sixth
#: is 1/6 of the first, and a line still named at a higher alias is left to the other rules).
COUNT_ALIAS_HARMONICS = 6


def position_quantum(position: np.ndarray, rough: float) -> float | None:
    """The record's position quantum ``q`` refined from its smallest step ``rough``: least squares of
    ``x − x_min = q·n`` with ``n`` rounded, over ever larger spans (10², 10³, … quanta) so that the
    rounding stays right; None if the positions are not integer multiples of one quantum
    (rms misfit above 0.1 q, e.g. a filtered or pre-decimated record).

    Parameters
    ----------
    position : ndarray, shape (N,)
        Logged position [rad or m].
    rough : float
        Smallest non-zero step [rad or m] (:attr:`plant.calibration.fit.Prepared.position_resolution`);
        its relative error from the log's printed digits is ~1e-8, too coarse for a count rate of
        10⁵ counts/s.
    """
    if not rough > 0:
        return None
    x = np.asarray(position, float) - float(np.min(position))
    q = float(rough)
    for lim in (1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9):
        sel = x <= lim * q
        n = np.round(x[sel] / q)
        nn = float(n @ n)
        if nn > 0:
            q = float(x[sel] @ n) / nn
        if sel.all():
            break
    miss = x - q * np.round(x / q)
    return q if float(np.sqrt(np.mean(miss**2))) < 0.1 * q else None


def constant_speed_runs(prep: Prepared) -> tuple[list[tuple[float, float]], float | None]:
    """The record's constant-speed runs as ``(count rate [counts/s], duration [s])`` and its position
    quantum [rad or m], for :func:`_count_alias`; no runs and None when the logged position is not
    quantised (:func:`position_quantum`) or the record was reduced before the fit (a long record's
    pre-decimation filters the position).

    A run is a stretch of one direction whose filtered speed stays within
    :data:`COUNT_ALIAS_SPEED_TOL` of its median for at least :data:`COUNT_ALIAS_MIN_RUN_S`; its count
    rate is the slope of the *logged* (quantised) position over the run divided by the quantum: the
    mean rate at which the encoder's counts pass, known to ~1e-9 relative over a run of seconds.
    """
    rec = prep.record
    if "pre_decimation" in rec.extra or prep.t.size < 3:
        return [], None
    q = position_quantum(rec.position, prep.position_resolution)
    if q is None:
        return [], None
    n0 = rec.position.size - prep.t.size   # prepare drops samples at the start only
    t, dq, x = prep.t, prep.dq, rec.position[n0:]
    vmax = float(np.percentile(np.abs(dq), 99))
    if not vmax > 0:
        return [], q
    moving = np.abs(dq) > 0.02 * vmax
    sgn = np.sign(dq)
    # one direction's moving stretches: boundaries where moving or the sign changes
    edge = np.flatnonzero(np.diff(moving.astype(int)) != 0) + 1
    edge = np.union1d(edge, np.flatnonzero(np.diff(sgn) != 0) + 1)
    out = []
    for a, b in zip(np.r_[0, edge], np.r_[edge, t.size]):
        if b - a < 3 or not moving[a]:
            continue
        med = float(np.median(dq[a:b]))
        ok = np.flatnonzero(np.abs(dq[a:b] - med) < COUNT_ALIAS_SPEED_TOL * abs(med)) + a
        if ok.size < 3:
            continue
        runs = np.split(ok, np.flatnonzero(np.diff(ok) > 1) + 1)
        r = max(runs, key=len)
        d = float(t[r[-1]] - t[r[0]])
        if d >= COUNT_ALIAS_MIN_RUN_S:
            v = float(np.polyfit(t[r] - t[r[0]], x[r], 1)[0])
            out.append((abs(v) / q, d))
    return out, q


def _count_alias(fit: FitResult, kind: str, slot: int, runs: list[tuple[float, float]], q: float | None,
                 fs_hz: float) -> str | None:
    """None unless a time or position line sits, on most of the record's constant-speed time, at an
    alias of the encoder's count rate; then why the record cannot tell it from the measurement chain.

    A velocity loop that differences quantised counts sees a quantisation error that is a sawtooth
    in the position, one period per count: at a constant speed a line at ``k·r`` Hz and its
    harmonics (``r`` the count rate, 10³–10⁵ Hz), which the loop turns into torque. A log that samples
    the torque at ``fs`` without an anti-alias filter folds it to ``|k·r − m·fs|``, a low frequency
    that keeps its phase along the position — a line with ``x = A/(J·ω²)`` of many quanta at the
    alias, none at the real ``k·r``, so :func:`_line_resolved` cannot see it. Found on independent
    record 12707 (session 40, docs/calibration.md): a clean sweep whose passes all run at one speed,
    a position line named at 7.823 Hz (55 % of the residual) where the count rate's first alias is at
    7.834 Hz, and its second and third harmonics refused at 15.65 and 23.45 Hz.

    The test: on each run ``(r, d)`` from :func:`constant_speed_runs`, the line's frequency there
    (a time line's ``f``; a position line's ``r·q/P``) lies within one Rayleigh bin ``1/d`` of
    ``|k·r − m·fs|`` for some ``k ≤`` :data:`COUNT_ALIAS_HARMONICS`; the line is refused if that holds
    on at least half of the runs' time (a real line at one speed meets an alias by chance with
    probability about ``K·2/(d·fs/2)``, under 1 % on the benchmark's records).

    Parameters
    ----------
    fit : FitResult
        The candidate's fit.
    kind, slot : str, int
        ``"time_periodic"`` or ``"position_periodic"`` and the line's index; other kinds return None.
    runs : list of (float, float)
        ``(count rate [counts/s], duration [s])`` per run (:func:`constant_speed_runs`).
    q : float or None
        The position quantum [rad or m] (:func:`position_quantum`); None: no test.
    fs_hz : float
        The log's sample rate [Hz].
    """
    if kind not in ("time_periodic", "position_periodic") or not runs or q is None or not q > 0:
        return None
    if kind == "time_periodic":
        hit, worst = count_alias_share(fit.spec.time_frequencies[slot], None, runs, q, fs_hz)
    else:
        hit, worst = count_alias_share(None, 1.0 / fit.spec.position_periods[slot], runs, q, fs_hz)
    if hit < 0.5:
        return None
    return (f"on {100 * hit:.0f} % of the constant-speed time the line lies within one frequency bin "
            f"(≤ {worst:.3g} Hz off) {COUNT_ALIAS_WHAT.format(fs=fs_hz)}: the quantisation of the loop's feedback "
            "sampled by the log, the measurement chain's structure, not a torque on the axis")


#: How :func:`_count_alias` and the ``unexplained`` notes name the alias.
COUNT_ALIAS_WHAT = ("of an alias of the encoder's count rate folded by the log's {fs:.4g} Hz "
                    f"(|k·r − m·fs|, k ≤ {COUNT_ALIAS_HARMONICS})")


def count_alias_share(f_hz: float | None, nu: float | None, runs: list[tuple[float, float]], q: float,
                      fs_hz: float) -> tuple[float, float]:
    """The fraction of the constant-speed time on which a line lies within one Rayleigh bin ``1/d``
    of an alias ``|k·r − m·fs|`` (``k ≤`` :data:`COUNT_ALIAS_HARMONICS`) of the run's count rate
    ``r``, and the largest such distance [Hz] (see :func:`_count_alias`).

    Parameters
    ----------
    f_hz : float or None
        A time line's frequency [Hz]; or None and ...
    nu : float or None
        ... a position line's frequency [cycles/rad or cycles/m], which on a run is ``r·q·nu`` Hz.
    runs : list of (float, float)
        ``(count rate [counts/s], duration [s])`` (:func:`constant_speed_runs`), not empty.
    q : float
        The position quantum [rad or m].
    fs_hz : float
        The log's sample rate [Hz].
    """
    total = sum(d for _, d in runs)
    hit = 0.0
    worst = 0.0
    for r, d in runs:
        f = f_hz if f_hz is not None else r * q * nu
        near = min(abs(min((k * r) % fs_hz, fs_hz - (k * r) % fs_hz) - f) for k in range(1, COUNT_ALIAS_HARMONICS + 1))
        if near < 1.0 / d:
            hit += d
            worst = max(worst, near)
    return (hit / total if total > 0 else 0.0), worst


def _beats_gear_spring(prep: Prepared, cur: FitResult, c: dict[str, Any], cfg: LoopConfig,
                       cache: dict[str, Any] | None = None, zc: float | None = None) -> str | None:
    """None if the reversal candidate ``c`` predicts held-out blocks better than the current model
    with the declared gear spring in it, else why not.

    A motor-side record of a compliant drive shows the spring's wind-up at every reversal: the
    load sticks until the spring carries ``Fc`` (:func:`plant.calibration.fit.geared_coulomb`), and
    without that spring in the model the nearest reversal kind (pre-sliding, backlash) takes it.
    With the stiffness declared the spring is known, so a reversal effect must describe more than
    it: its cross-validated gain over the current model *with the spring* must be positive. A point
    estimate, not a significance test: the candidate has already passed the rule against the
    current model, and a gain at a few reversals could never be significant (:func:`min_events`).
    ``Fc`` is the current fit's Coulomb level, refitted with the spring to its fixed point
    (:func:`_spring_coulomb`; twice only, before session 50). Not
    applied when the spring's swing ``2Fc/K`` spans fewer than :data:`MIN_TRANSITION_COUNTS`
    quanta (it is then a step, as the plain Coulomb column is).

    Before that, a pre-sliding candidate must leave a resolved bristle: a LuGre bristle (initial
    slope ``2k·Fc``) in series with the spring (``K``) gives ``1/k_fit = 1/k_bristle + 2Fc/K``, so
    ``1/k − 2Fc/K`` (``Fc`` the candidate's) must be at least :data:`MIN_TRANSITION_COUNTS`
    quanta — the resolution rule of :func:`_resolved` applied to the bristle. A transition shorter
    than the spring's own swing is not a bristle behind that spring. Cost: a real bristle much
    shorter than a soft gear's swing is refused as unresolved. docs/calibration.md, "Session 20".

    ``cache``: one dict per loop step (same ``cur``), so the spring model is fitted and
    cross-validated once for all of the step's candidates.

    Where a backlash candidate loses to the spring and ``zc`` is given, the question is asked again
    with the load's inertia (session 38, :func:`plant.calibration.two_mass.gap_against_compliance`):
    a gap in the declared gear against the same two-mass drive without one, at the run's level ``zc``.
    From session 38 to 56 a gap that predicted better there was named; since session 57 the answer
    is only reported in the refusal (:data:`GAP_NOT_TOLD`): on the 400 used records 24060–24259 it
    named compliant modes only, and refusing it gained one and lost none on never-used ones
    (docs/calibration.md, "Session 57, second change"); its cost is a real gap the massless spring
    explains as well (used blind 12046).

    Where the current fit's Coulomb level is 0 (a rigid fit of a soft drive: the motor sees the friction
    through the spring's wind-up, a ramp the step column cannot take, so the bound holds it at 0) the
    spring's fixed point starts from the candidate's own Coulomb level (session 50; once per step and
    kind in ``cache``). Before, the spring had no swing there and the candidate no test: blind records
    20390 and 20442, soft drives without a gap, were named backlash.
    """
    k = cfg.gear_stiffness
    need = MIN_TRANSITION_COUNTS * prep.position_resolution
    pk = c["fit"].spec.presliding_k
    fc_c = _coulomb(c["fit"])
    if pk is not None and k and fc_c > 0:
        # a bristle in series with the spring: 1/k_fit = 1/k_bristle + 2Fc/K (initial slopes 2kFc and K)
        bristle = 1.0 / pk - 2.0 * fc_c / k
        if bristle < need:
            return (f"with the declared gear spring (K = {k:.4g}) the pre-sliding transition 1/k = {1.0 / pk:.3g} leaves a "
                    f"bristle of 1/k − 2Fc/K = {bristle:.3g}, under {MIN_TRANSITION_COUNTS:g} position quanta ({need:.3g}): "
                    "a bristle in series with the gear cannot shorten its transition — the gear's wind-up, not pre-sliding")
    cache = {} if cache is None else cache
    if "loss" not in cache:
        cache["loss"] = _gear_spring_losses(prep, cur, cfg, cache)
    spring = cache["loss"]
    seeded = ""
    if spring is None and not _coulomb(cur) > 0 and fc_c > 0 and not cur.spec.geared:
        # session 50: a rigid fit of a soft drive can put its Coulomb level at the bound 0 (the motor sees the
        # friction through the spring's wind-up, a ramp the step column does not describe), and the spring then
        # had no swing and the candidate no test. Its fixed point starts from the candidate's own level instead.
        key = ("seeded", c["kind"])
        if key not in cache:
            cache[key] = _gear_spring_losses(prep, cur, cfg, cache, seed=fc_c)
        spring = cache[key]
        if spring is not None:
            seeded = (f" (the current model's Coulomb level is 0, so the spring's was started from the candidate's, "
                      f"{fc_c:.3g})")
            c["spring_seed"] = fc_c
    if spring is None:
        if c["kind"] == "backlash" and zc is not None:
            _untested_spring(prep, cur, c, cfg, zc, cache)      # report only (session 54)
        return None
    loss, swing = spring
    g, z = cv_compare(loss, c["loss"])
    c["gain_over_spring_pct"], c["z_over_spring"] = g, z
    if g > 0:
        return None
    why = (f"the declared gear spring (K = {k:.4g}, swing 2Fc/K = {swing:.3g}){seeded} in the current model predicts "
           f"held-out blocks as well: the candidate's gain over it is {g:.2f} % (z = {z:.1f}) — the reversal transition "
           "is the gear's wind-up")
    if c["kind"] != "backlash" or zc is None:
        return why
    # session 38: the massless play lost to the massless spring; ask the question with the load's inertia —
    # does a gap in the gear predict better than the same two-mass drive without one (a compliant mode)?
    from plant.calibration.two_mass import gap_against_compliance   # two_mass imports this module
    width = c["fit"].spec.backlash_width or 0.0
    g2, z2, info = gap_against_compliance(prep, cur, k, width, cfg.k_folds)
    if predicts(g2, z2, zc):
        # session 57: reported, no longer a reason to name the gap (docs/calibration.md, "Session 57, second change")
        return why + (f"; with the load's inertia a gap of {info['gap']:.3g} in the declared gear predicts held-out blocks "
                      f"better than the same drive without one (gain {g2:.2f} %, z = {z2:.1f}), but {GAP_NOT_TOLD}")
    return why + (f"; with the load's inertia a gap does not predict better than a compliant mode either (gain {g2:.2f} %, "
                  f"z = {z2:.1f}{', ' + info['why'] if 'why' in info else ''})")


#: Why session 38's two-mass answer no longer names a backlash the massless spring explains as well (session 57).
GAP_NOT_TOLD = ("that two-mass description (load share and damping ratio fixed) does not tell a gap from a compliant "
                "mode it describes imperfectly: a gap is one more way to fit the ringing (session 57)")


def _viscous_split_predicts(prep: Prepared, c: dict[str, Any], zc: float, cfg: LoopConfig) -> str | None:
    """None if the ``asymmetric_friction`` candidate ``c`` also predicts held-out blocks better
    than its twin with a symmetric viscous term, else why not.

    With an offset in the model an asymmetric Coulomb level is that offset again while the axis
    moves (``Fc± = Fc ± offset``, :func:`plant.calibration.fit.design`): the two differ only where
    the Coulomb column is not ±1 — at rests and across the Coulomb ramp, where the model is least
    trustworthy. What the record can attribute to direction-dependent friction is the split of the
    viscous term, so the candidate must pass the acceptance rule (gain > 0, ``z ≥ zc``) against
    the same model with the Coulomb term split and the viscous term symmetric
    (``ModelSpec.coulomb_split``). Unlike a reversal effect, the viscous split acts on every moving
    sample, so a real one can be significant. docs/calibration.md, "Session 21".
    """
    twin = dataclasses.replace(c["fit"].spec.copy(), asymmetric=False, coulomb_split=True)
    g, z = cv_compare(cv_losses(prep, twin, cfg.k_folds), c["loss"])
    c["gain_over_coulomb_split_pct"], c["z_over_coulomb_split"] = g, z
    if predicts(g, z, zc):
        return None
    return (f"its gain comes from the split Coulomb level, which with the offset in the model is the offset acting only "
            f"while the axis moves (it differs from it only at rests): against that twin, with the viscous friction "
            f"symmetric, the direction-dependent viscous friction gains {g:.2f} % (z = {z:.1f}; needs > 0 and "
            f"z ≥ {zc:.2f}) — no asymmetry the record can attribute")


#: The declared spring's Coulomb level (:func:`_spring_coulomb`) is refitted until it moves by less than this
#: fraction of itself (a numerical tolerance of the fixed point, not a threshold on the data; session 50)
SPRING_COULOMB_RTOL = 1e-3
#: ... or at most this many times (a guard against a slow or oscillating iteration; on session 50's probe
#: record it converged in about ten)
SPRING_COULOMB_MAX_REFITS = 40


def _spring_coulomb(prep: Prepared, cur: FitResult, cfg: LoopConfig, seed: float | None = None,
                    fixed_points: dict[float | None, float | None] | None = None) -> float | None:
    """The Coulomb level [N·m or N] that sets the declared spring's swing ``2Fc/K``: the fixed point of
    refitting the current model with the spring in it, started from the current fit's level; None
    without a declared stiffness, for a model whose friction already acts through it, where the
    level does not stay positive, or where the swing is under :data:`MIN_TRANSITION_COUNTS` quanta
    (the spring is then a step, as the plain Coulomb column is).

    Session 50: iterated to convergence (:data:`SPRING_COULOMB_RTOL`), not twice. A rigid fit of a
    soft drive sees the friction through the spring's wind-up, a ramp the step column takes only in
    part, so its Coulomb level can be far below the level the spring model settles on (a record
    written in ``tests/test_calibration_spring_seed.py``: 0.037 against the fixed point 0.464 N·m,
    which two refits left at 0.337), and the spring in the test then stood for less friction than it
    describes. The fixed point is the level the massless spring needs to describe the record, not an
    estimate of the drive's Coulomb friction (0.31 N·m on that record).

    ``seed`` [N·m or N]: where the current fit's Coulomb level is not positive (the bound holds it at 0,
    itself a fixed point of a spring without swing) the refits start from it instead (a reversal
    candidate's own level, :func:`_beats_gear_spring`).

    ``fixed_points``: where given, the fixed point before the swing check is stored in it under
    ``seed`` (the step's cache, so that :func:`_untested_spring` need not iterate again)."""
    k = cfg.gear_stiffness
    fc = _spring_fixed_point(prep, cur, cfg, seed)
    if fixed_points is not None:
        fixed_points[seed] = fc
    if fc is None or 2.0 * fc / k < MIN_TRANSITION_COUNTS * prep.position_resolution:
        return None
    return fc


def _spring_fixed_point(prep: Prepared, cur: FitResult, cfg: LoopConfig, seed: float | None = None) -> float | None:
    """The fixed point of :func:`_spring_coulomb` [N·m or N] before its swing is compared with the
    position quantum; None without a declared stiffness, for a model whose friction already acts
    through the spring, or where the level does not stay positive (no spring with friction through
    it describes the record better than none, :func:`_untested_spring`)."""
    k = cfg.gear_stiffness
    fc = _coulomb(cur)
    if not fc > 0 and seed is not None:
        fc = seed
    if cur.spec.geared or not (k and fc > 0):
        return None
    for _ in range(SPRING_COULOMB_MAX_REFITS):
        new = _coulomb(fit_model(prep, dataclasses.replace(cur.spec.copy(), gear_stiffness=k, spring_coulomb=fc), refine=False))
        if not new > 0:
            return None
        done = abs(new - fc) <= SPRING_COULOMB_RTOL * new
        fc = new
        if done:
            break
    return fc


#: Phrase of :func:`_untested_spring`'s caveat in an effect's evidence (session 54).
UNTESTED_SPRING = "the declared gear spring could not be tested"


def _untested_spring(prep: Prepared, cur: FitResult, c: dict[str, Any], cfg: LoopConfig, zc: float,
                     cache: dict[str, Any]) -> None:
    """Say so in a backlash candidate's evidence where its declared spring could not be tested
    (session 54; called by :func:`_beats_gear_spring`). Report only: the candidate is not refused.

    With the stiffness declared the engineer has said the drive is compliant, and a compliant mode
    without a gap shows a transition at every reversal that a play takes for a gap. The spring test of
    :func:`_beats_gear_spring` asks that question with the massless spring, but it has no spring to
    test where the spring's Coulomb level does not stay positive when the model is refitted with it
    (:func:`_spring_fixed_point` None, also when started from the candidate's own level): no spring
    with friction through it describes the record, typically a rigid fit of a drive whose mode rings
    in the fit's band. The candidate then passes with no test of the spring (independent 22019: a
    7.8 Hz compliant mode without a gap, named backlash). Here the session-38 question is asked for
    the report (:func:`plant.calibration.two_mass.gap_against_compliance`, a gap against the same
    two-mass drive without one at the run's level ``zc``) and its answer, or why it could not be
    asked, is added to the evidence. ``cache``: the step's (:func:`_beats_gear_spring`), whose fixed
    points (:func:`_spring_coulomb`) tell "no positive level" from "a swing under the resolution"
    without iterating again.

    Why not a refusal: refusing where that question fails or cannot be asked was decided on never-used
    seeds and not kept — it acted on none of 400 two-mass records (22760–23959, both generators), a
    tie; on 22019 itself a position line took the backlash's place, a wrong kind either way
    (docs/calibration.md, "Session 54").

    Not applied where the spring's fixed point is positive but its swing spans fewer than
    :data:`MIN_TRANSITION_COUNTS` quanta (the spring is then a step, as the Coulomb column is), nor
    without a declared stiffness or in a model already geared.
    """
    k = cfg.gear_stiffness
    if not k or cur.spec.geared:
        return
    fc_c = _coulomb(c["fit"])
    # the attempt _beats_gear_spring made last: from the candidate's level where the current one is not positive
    seed = fc_c if not _coulomb(cur) > 0 and fc_c > 0 else None
    fps = cache.get("fixed_points", {})
    if (fps[seed] if seed in fps else _spring_fixed_point(prep, cur, cfg, seed)) is not None:
        return     # a spring exists; its swing is under the resolution (the spring is a step)
    from plant.calibration.two_mass import gap_against_compliance   # two_mass imports this module
    g2, z2, info = gap_against_compliance(prep, cur, k, c["fit"].spec.backlash_width or 0.0, cfg.k_folds)
    if predicts(g2, z2, zc):
        answer = (f"with the load's inertia a gap of {info['gap']:.3g} in the declared gear predicts held-out blocks "
                  f"better than the same drive without one (gain {g2:.2f} %, z = {z2:.1f})")
    else:
        answer = (f"with the load's inertia a gap does not predict better than the declared gear's compliant mode "
                  f"(gain {g2:.2f} %, z = {z2:.1f}{'; ' + info['why'] if 'why' in info else ''}; needs > 0 and "
                  f"z ≥ {zc:.2f}): the record may not tell a gap from the gear's compliance")
    c["evidence"] = (c.get("evidence", "") + f"; caution: {UNTESTED_SPRING} (K = {k:.4g}: its Coulomb level does not "
                     f"stay positive when the model is refitted with the spring in it, also when started from the "
                     f"candidate's {fc_c:.3g}), and {answer} (session 54)")


def _step_spring_coulomb(prep: Prepared, cur: FitResult, cfg: LoopConfig, cache: dict[str, Any]) -> float | None:
    """:func:`_spring_coulomb`, once per loop step (``cache``: the step's dict, shared by the backlash
    candidate and :func:`_beats_gear_spring`)."""
    if "fc" not in cache:
        cache["fc"] = _spring_coulomb(prep, cur, cfg, fixed_points=cache.setdefault("fixed_points", {}))
    return cache["fc"]


def _gear_spring_losses(prep: Prepared, cur: FitResult, cfg: LoopConfig,
                        cache: dict[str, Any], seed: float | None = None) -> tuple[np.ndarray, float] | None:
    """CV prediction errors of the current model with the declared spring in it, and the spring's
    swing ``2Fc/K``; None where :func:`_spring_coulomb` is None. With ``seed`` the spring's Coulomb
    level is started from it (:func:`_spring_coulomb`), not taken from the step's ``cache``."""
    fc = (_step_spring_coulomb(prep, cur, cfg, cache) if seed is None else
          _spring_coulomb(prep, cur, cfg, seed, fixed_points=cache.setdefault("fixed_points", {})))
    if fc is None:
        return None
    spring = dataclasses.replace(cur.spec.copy(), gear_stiffness=cfg.gear_stiffness, spring_coulomb=fc)
    return cv_losses(prep, spring, cfg.k_folds), 2.0 * fc / cfg.gear_stiffness


def fit_band_hz(prep: Prepared) -> float:
    """The band the fit sees [Hz]: the lower of the position filter's cut-off and the decimation
    filter's (:data:`plant.calibration.fit.DECIMATION_CUTOFF` × the decimated Nyquist frequency)."""
    return min(float(prep.cutoff_hz), DECIMATION_CUTOFF * 0.5 / (prep.dt_s * prep.decim))


def spring_mode_floor_hz(stiffness: float, inertia: float) -> float | None:
    """Lowest possible mode [Hz] of a drive of total inertia ``inertia`` [kg·m² or kg] split by a
    spring ``stiffness`` [N·m/rad or N/m]: ``ω² = K (1/J_m + 1/J_l)`` is smallest at ``J_m = J_l
    = J/2``, so ``f ≥ sqrt(K/J)/π``. None for a non-positive inertia."""
    if not inertia > 0:
        return None
    return math.sqrt(stiffness / inertia) / math.pi


def _quasi_static_spring(prep: Prepared, cur: FitResult, cfg: LoopConfig) -> tuple[float, float] | None:
    """``(f_min, band)`` [Hz] if the declared spring's lowest possible mode lies above the fit's band
    (the load then follows the spring quasi-statically in the data, as :func:`plant.calibration.fit.
    geared_coulomb` assumes), else None. docs/calibration.md, "Session 35"."""
    if not cfg.gear_stiffness or "inertia" not in cur.names:
        return None
    f_min = spring_mode_floor_hz(cfg.gear_stiffness, cur.param("inertia"))
    band = fit_band_hz(prep)
    return (f_min, band) if f_min is not None and f_min > band else None


#: The gap's source in a report: refitted inside the declared spring, or the formula of :func:`backlash_gap`.
GAP_REFITTED = "refitted with the gap inside the declared gear spring (geared_gap)"
GAP_FORMULA = "the width minus half the spring's wind-up (backlash_gap)"


def geared_gap(prep: Prepared, fit: FitResult, stiffness: float) -> tuple[float | None, dict[str, Any]]:
    """The gear's gap refitted with the declared spring in the model, after the loop: (gap or None, how).

    The loop names backlash with a play on the logged position, whose width is the motion lost at
    a reversal (:func:`backlash_gap`). Given the drive's stiffness ``K`` the final model is refitted
    with friction acting through the spring and the gap in its middle
    (:func:`plant.calibration.fit.geared_coulomb`: the spring unwinds ``Fc/K``, the gap is crossed,
    the spring winds up ``Fc/K``), only the gap free: a log grid from :data:`MIN_TRANSITION_COUNTS`
    quanta to the fitted width, then refined. ``Fc`` sets the swing and is the fit's own Coulomb
    level refitted with the spring (two passes, a fixed point, as the spring check of the loop).
    The named effects do not change: the decision is the loop's, only the gap is estimated here.
    Measured in docs/calibration.md, "Session 32" (decided on never-used seeds 4600–4659).

    Parameters
    ----------
    prep : Prepared
    fit : FitResult
        The loop's final fit, with ``backlash_width`` set [rad or m].
    stiffness : float
        Declared stiffness between the logged position and the load [N·m/rad or N/m].

    Returns
    -------
    (float or None, dict)
        The gap [rad or m] and ``{"method", "swing"}`` (``swing = 2Fc/K`` [rad or m]); None where
        the spring's swing or the width spans fewer than :data:`MIN_TRANSITION_COUNTS` quanta, or
        the Coulomb level is not positive (the caller then uses :func:`backlash_gap`).

    Raises
    ------
    ValueError
        ``stiffness`` is not a positive finite number, or ``fit`` has no backlash.
    """
    check_stiffness(stiffness)
    width = fit.spec.backlash_width
    if width is None:
        raise ValueError("geared_gap: the fit has no backlash width")
    lo = MIN_TRANSITION_COUNTS * prep.position_resolution
    fc = _coulomb(fit)
    if not fc > 0 or 2.0 * fc / stiffness < lo or not width > lo:
        return None, {"method": GAP_FORMULA, "swing": 2.0 * max(fc, 0.0) / stiffness}
    best = None
    for _ in range(2):   # the Coulomb level that sets the swing, refitted with the spring and the gap
        base = dataclasses.replace(fit.spec.copy(), gear_stiffness=stiffness, spring_coulomb=fc)
        best = None
        for g in np.logspace(math.log10(lo), math.log10(width), 14):
            f = fit_model(prep, dataclasses.replace(base.copy(), backlash_width=float(g)), refine=False)
            if best is None or f.rss < best.rss:
                best = f
        i = _hyper_index(best.spec, "backlash_width")
        best = fit_model(prep, best.spec, free=[i], rel_bounds={i: 0.6})
        fc_new = _coulomb(best)
        if not fc_new > 0 or 2.0 * fc_new / stiffness < lo:
            return None, {"method": GAP_FORMULA, "swing": 2.0 * max(fc_new, 0.0) / stiffness}
        fc = fc_new
    return float(best.spec.backlash_width), {"method": GAP_REFITTED, "swing": 2.0 * fc / stiffness}


def _replaces_inertia(cur: FitResult, new: FitResult) -> str | None:
    """None unless the candidate fit drives a positive inertia to its bound 0, else why it is refused.

    An axis has a positive inertia, so a term the fit can use only by pushing the inertia to 0 is
    standing in for the inertia, not describing a torque of its own. It happens when a smooth
    column follows the acceleration: on a sinusoid trajectory ``sin θ`` and a time line at the
    motion's frequency are both nearly ``−θ̈/ω²``, and they carry none of the noise the measured
    acceleration has (the encoder's quantisation, differentiated twice, and the velocity loop's
    reaction to the same counts, which is in the logged torque). Found on benchmark seed 42 (clean,
    sinusoid): gravity with a 26 % gain, the inertia 13.7 → 0; on the same record without the
    position quantisation the gain is 0 % (docs/calibration.md, "Session 14"). When the current
    model already has no inertia the rule does not apply: the candidate may be what repairs it.
    """
    if "inertia" not in cur.names or "inertia" not in new.names:
        return None
    j0, j1 = cur.param("inertia"), new.param("inertia")
    if j0 > 0 and j1 <= 0:
        return (f"takes the inertia's place: with it the inertia falls from {j0:.4g} to its bound 0, so the term stands "
                "in for the (noisy) measured acceleration rather than describing a torque of its own")
    return None


def _removes_friction(cur: FitResult, new: FitResult) -> str | None:
    """None unless the direction split drives a positive friction level to its bound 0, else why it is refused.

    With the split the offset is absorbed into the two levels (``coulomb_pos = Fc + offset``,
    ``coulomb_neg = Fc − offset``, :func:`plant.calibration.fit.design`), so the current model's own
    levels while moving are ``Fc ± offset``. Where the current model has a positive level in a
    direction and the asymmetric fit can use the split only by pushing that direction's level to its
    bound 0 (unbounded, below it: a torque that helps the motion), the split is not describing that
    direction's friction — a drive's friction opposes motion both ways — but standing in for a torque
    of something else, as :func:`_replaces_inertia` for the inertia. Found on blind records whose
    hidden effect is a compliant mode (24950, 24994, 25174) or a backlash (24886): the split took
    17–44 % of the held-out error with one level at 0 and the viscous slopes up to 6× apart, while
    on 60 records of either generator that hide asymmetric friction none of the 45 named splits had
    a level at its bound (session 58, docs/calibration.md). When the current model already has no friction in
    that direction (``Fc ± offset ≤ 0``: an offset as large as the friction) the rule does not
    apply: the split may be what describes it.
    """
    if not {"coulomb", "offset"} <= set(cur.names) or not {"coulomb_pos", "coulomb_neg"} <= set(new.names):
        return None
    fc, off = _coulomb(cur), cur.param("offset")
    for name, level, word in (("coulomb_pos", fc + off, "v > 0"), ("coulomb_neg", fc - off, "v < 0")):
        if level > 0 and new.param(name) <= 0:
            return (f"takes a direction's friction away: the split puts the Coulomb level for {word} at its bound 0, "
                    f"where the model without it has {level:.4g} there (Fc {fc:.4g} with the offset {off:+.4g}), so "
                    "the split stands in for a torque that is not that direction's friction (friction opposes "
                    "motion both ways)")
    return None


def friction_levels(fit: FitResult) -> tuple[float, float]:
    """Coulomb level ``Fc`` and static level ``Ts`` of a fit (the mean of the two directions when
    friction is asymmetric; the mean over the record's time when a friction drift is in the model,
    :func:`_coulomb`; ``Ts = Fc`` when no Stribeck term was fitted), both ≥ 0 [N·m or N]."""
    fc = max(_coulomb(fit), 0.0)
    return fc, (fc + max(fit.param("stribeck"), 0.0)) if "stribeck" in fit.names else fc


def check_stiffness(stiffness: float, name: str = "gear stiffness") -> float:
    """Return ``stiffness`` if it is a positive finite number [N·m/rad or N/m].

    Raises
    ------
    ValueError
        Otherwise, naming ``name`` (e.g. the command-line option) and what was expected.
    """
    if not (math.isfinite(stiffness) and stiffness > 0):
        raise ValueError(f"{name}: expected a positive stiffness [N·m/rad, or N/m for a linear drive], got {stiffness!r}")
    return stiffness


def backlash_gap(width: float, coulomb: float, static: float, stiffness: float) -> float:
    """The gear's gap from the fitted backlash width, given the drive's stiffness.

    The play operator on the logged (motor-side) position measures the motion lost at a reversal,
    and in a compliant drive that is more than the gap: after the reversal the gear spring first
    unwinds the friction torque it carried (``≈ Fc/k`` of travel), then the gap is crossed, then
    the spring winds up until the load breaks away (``Ts/k``). The fitted play replaces each ramp
    of transmitted torque by a step, which least squares puts near the ramp's middle, so the width
    is the gap plus *half* the wind-up::

        width ≈ gap + (Fc + Ts) / (2 k)      →      gap = max(width − (Fc + Ts)/(2k), 0)

    Measured, not assumed (docs/calibration.md, "Session 15"): on 7 fresh backlash records of the
    independent generator (seeds 3200–3219, never used before) the width was within 30 % of the gap
    on 4 (median error 16 %) and within 30 % of ``gap + (Fc + Fs)/(2k)`` on all 7 (median 4 %).

    Parameters
    ----------
    width : float
        Fitted backlash width [rad or m].
    coulomb, static : float
        The fit's Coulomb and static friction levels [N·m or N] (:func:`friction_levels`).
    stiffness : float
        Stiffness of the drive between the logged position and the load [N·m/rad or N/m]; an
        engineer's value from the drive's design (e.g. the paper's Table 1: 3.08e6 N·m/rad).

    Returns
    -------
    float
        The gap [rad or m], ≥ 0.

    Raises
    ------
    ValueError
        ``stiffness`` is not a positive finite number.
    """
    check_stiffness(stiffness)
    return max(width - 0.5 * (max(coulomb, 0.0) + max(static, 0.0)) / stiffness, 0.0)


def _coulomb(fit: FitResult) -> float:
    """The fit's Coulomb level [N·m or N] averaged over the record's time.

    With the out-of-library ``friction_drift`` description in the model the Coulomb torque is
    ``(Fc + c₁τ + c₂τ²)·sign``: the level is carried by all three coefficients, and the fit may put
    ``Fc`` (the level at τ = 0) at its bound 0 while the drift columns carry the whole level. Its
    mean over the record, ``Fc + c₁/2 + c₂/3``, is what the rules that need a Coulomb level (the
    declared gear spring's swing ``2Fc/K``, the bristle behind it, σ0 = ``k·Fc``, the backlash gap)
    must see — before session 31 they read ``Fc`` alone, 0 on independent seed 55, and skipped the
    gear-spring check there (docs/calibration.md, "Session 31").
    """
    if "coulomb" in fit.names:
        level = fit.param("coulomb")
    else:
        level = 0.5 * (fit.param("coulomb_pos") + fit.param("coulomb_neg"))
    # means of the drift's time columns over a uniformly sampled record (τ from 0 to 1): mean(τ) = 1/2,
    # the second column's from fit.drift_shape_mean (1/3 for τ²)
    # (the heating shapes, fit.heating_shapes, have mean 1 by construction)
    means = ((1.0, 1.0) if fit.spec.drift_heating
             else (0.5, drift_shape_mean(fit.spec.drift_time_constant)))
    for name, mean in zip(("nz_drift_c1", "nz_drift_c2"), means):
        if name in fit.names:
            level += mean * fit.param(name)
    return level


def effect_from_fit(fit: FitResult, kind: str, slot: int | None) -> Effect:
    """Build the :mod:`plant.effects` object for an accepted effect from the fitted parameters."""
    s = fit.spec
    if kind == "asymmetric_friction":
        return build_effect(
            {
                "kind": kind,
                "viscous_pos_nm_s_rad": max(fit.param("viscous_pos"), 0.0),
                "viscous_neg_nm_s_rad": max(fit.param("viscous_neg"), 0.0),
                "coulomb_pos_nm": max(fit.param("coulomb_pos"), 0.0),
                "coulomb_neg_nm": max(fit.param("coulomb_neg"), 0.0),
            }
        )
    if kind == "presliding":
        return build_effect(
            {
                "kind": kind,
                "sigma0_nm_rad": float(s.presliding_k) * max(_coulomb(fit), 1e-12),
                "sigma1_nm_s_rad": max(fit.param("presliding_damping"), 0.0),
            }
        )
    if kind == "backlash":
        return build_effect({"kind": kind, "width_rad": float(s.backlash_width)})
    if kind == "position_periodic":
        a, b = fit.param(f"pos{slot}_sin"), fit.param(f"pos{slot}_cos")
        return build_effect(
            {"kind": kind, "period_rad": float(s.position_periods[slot]), "amplitude_nm": math.hypot(a, b), "phase_rad": math.atan2(b, a)}
        )
    if kind == "gravity_imbalance":
        a, b = fit.param("grav_sin"), fit.param("grav_cos")
        return build_effect({"kind": kind, "amplitude_nm": math.hypot(a, b), "phase_rad": math.atan2(b, a)})
    if kind == "time_periodic":
        a, b = fit.param(f"time{slot}_sin"), fit.param(f"time{slot}_cos")
        return build_effect(
            {"kind": kind, "frequency_hz": float(s.time_frequencies[slot]), "amplitude_nm": math.hypot(a, b), "phase_rad": math.atan2(b, a)}
        )
    raise ValueError(f"unknown effect kind {kind!r}; valid kinds: {sorted(EFFECT_KINDS)}")


# -- candidate builders, one per registered kind -------------------------------------------------------------------

@dataclasses.dataclass
class _Ctx:
    prep: Prepared
    cur: FitResult
    present: set[str]
    cfg: LoopConfig
    linear: bool
    span: float
    vmax: float
    #: the axis moves both ways (:func:`both_directions`, computed once per run)
    two_way: bool = True
    #: the declared spring's Coulomb level and model, once per step (:func:`_beats_gear_spring`)
    spring_cache: dict[str, Any] = dataclasses.field(default_factory=dict)
    #: the phase guard's lines on a periodic motion (fundamental [Hz], harmonics, odd only), else None
    #: (:func:`run_loop`; used by the heating drift's rival, :func:`_drift_candidate`)
    guard: tuple[float, int, bool] | None = None

    @property
    def unit_pos(self) -> str:
        return "m" if self.linear else "rad"


def _grid_then_fit(ctx: _Ctx, new: ModelSpec, name: str, values: np.ndarray, rel: float) -> FitResult:
    best = None
    for v in values:
        trial = new.copy()
        setattr(trial, name, float(v))
        f = fit_model(ctx.prep, trial, refine=False)
        if best is None or f.rss < best.rss:
            best = f
    i = _hyper_index(best.spec, name)
    return fit_model(ctx.prep, best.spec, free=[i], rel_bounds={i: rel})


#: Moving samples (``residuals.moving_mask``) each direction needs before a direction-dependent
#: friction is tried: the count below which ``residuals.velocity_profile`` cannot give that side's
#: slope, the candidate's own evidence (docs/calibration.md, "Session 32").
MIN_SAMPLES_PER_DIRECTION = 10


def both_directions(prep: Prepared) -> tuple[int, int]:
    """Moving samples (``residuals.moving_mask``) with ``w > 0`` and with ``w < 0`` on the decimated rows."""
    mov = res.moving_mask(prep.dq_dec)
    return int(np.count_nonzero(mov & (prep.dq_dec > 0))), int(np.count_nonzero(mov & (prep.dq_dec < 0)))


def _b_asymmetric(ctx: _Ctx) -> list[dict[str, Any]]:
    if "asymmetric_friction" in ctx.present:
        return []
    if not ctx.two_way:
        # one-way motion: the other direction's friction is not in the record (run_loop says so once)
        return []
    a = res.velocity_profile(ctx.prep.dq_dec, ctx.cur.residual)["asymmetry"]
    f = fit_model(ctx.prep, dataclasses.replace(ctx.cur.spec.copy(), asymmetric=True))
    return [{"kind": "asymmetric_friction", "slot": None, "fit": f, "group": "velocity",
             "evidence": f"residual slope against velocity differs between directions ({a['slope_pos']:.3g} for v>0, "
                         f"{a['slope_neg']:.3g} for v<0), mean residual {a['mean_pos']:.3g} (v>0) vs {a['mean_neg']:.3g} (v<0)"}]


def _reversal_candidate(ctx: _Ctx, kind: str) -> list[dict[str, Any]]:
    if ctx.present & REVERSAL_KINDS:
        return []
    rv = res.reversal_profile(ctx.prep.t_dec, ctx.prep.dq_dec, ctx.cur.residual)
    if rv["n_reversals"] == 0:
        return []
    lo = max(0.01 * ctx.vmax * ctx.prep.dt_s, MIN_TRANSITION_COUNTS * ctx.prep.position_resolution)
    hi = 0.05 * ctx.span
    if not hi > lo:
        return []
    grid = np.logspace(math.log10(lo), math.log10(hi), 14)
    if kind == "presliding":
        f = _grid_then_fit(ctx, dataclasses.replace(ctx.cur.spec.copy(), presliding_k=1.0), "presliding_k", 1.0 / grid, 0.6)
        what = "a LuGre bristle transition"
    else:
        qs = _quasi_static_spring(ctx.prep, ctx.cur, ctx.cfg)
        fc = _step_spring_coulomb(ctx.prep, ctx.cur, ctx.cfg, ctx.spring_cache) if qs is not None else None
        if fc is not None:
            # the drive's stiffness is declared and its mode lies above the fit's band: the gap sits
            # inside that (quasi-static) spring, so the fitted width is the gap itself, not the lost
            # motion gap + wind-up of a rigid play (sessions 31 and 35)
            k = ctx.cfg.gear_stiffness
            base = dataclasses.replace(ctx.cur.spec.copy(), gear_stiffness=k, spring_coulomb=fc, backlash_width=1.0)
            g_lo = MIN_TRANSITION_COUNTS * ctx.prep.position_resolution
            ggrid = np.logspace(math.log10(g_lo), math.log10(max(hi, 2 * g_lo)), 14)
            f = _grid_then_fit(ctx, base, "backlash_width", ggrid, 0.6)
            what = (f"a gap inside the declared gear spring (K = {k:.4g}, its swing 2Fc/K = {2 * fc / k:.3g}; its mode is "
                    f"at least {qs[0]:.3g} Hz, above the fit's band of {qs[1]:.3g} Hz, so the spring is quasi-static here)")
        else:
            f = _grid_then_fit(ctx, dataclasses.replace(ctx.cur.spec.copy(), backlash_width=1.0), "backlash_width", grid, 0.6)
            what = "a dead zone"
    return [{"kind": kind, "slot": None, "fit": f, "group": "reversal",
             "evidence": f"{rv['share_pct']:.0f} % of the residual energy lies within ±0.15 s of the {rv['n_reversals']} velocity "
                         f"reversals ({rv['time_share_pct']:.0f} % of the time), consistent with {what}"}]


def _b_presliding(ctx: _Ctx) -> list[dict[str, Any]]:
    return _reversal_candidate(ctx, "presliding")


def _b_backlash(ctx: _Ctx) -> list[dict[str, Any]]:
    return _reversal_candidate(ctx, "backlash")


def _b_position_periodic(ctx: _Ctx) -> list[dict[str, Any]]:
    out = []
    spec = ctx.cur.spec
    ps = res.position_spectrum(ctx.prep.q_dec, ctx.prep.dq_dec, ctx.cur.residual)
    for pk in res.find_peaks(ps, n_peaks=ctx.cfg.n_peaks):
        period = 1.0 / pk["frequency"]
        cycles = ctx.span / period
        if cycles < res.MIN_CYCLES:  # fewer than 2 cycles over the travel: not identifiable as periodic
            continue
        if not ctx.linear and _is_gravity_period(period):
            continue  # that is gravity_imbalance
        if any(abs(period - p) < 0.02 * p for p in spec.position_periods):
            continue
        new = spec.copy()
        new.position_periods.append(period)
        slot = len(new.position_periods) - 1
        i = _hyper_index(new, "position_periods", slot)
        # refine within two spectral bins of the peak (one bin = one cycle over the travel)
        f = fit_model(ctx.prep, new, free=[i], rel_bounds={i: min(0.25, 2.0 / cycles)})
        if not ctx.linear and _is_gravity_period(f.spec.position_periods[slot]):
            # refined onto one cycle per revolution: the columns are gravity_imbalance's, which is
            # tried on its own (session 29: a 10⁶-sample record over 17 turns named its gravity a
            # "position_periodic" of period 6.28320 rad, the tie broken by the candidates' order)
            continue
        out.append({"kind": "position_periodic", "slot": slot, "fit": f, "group": "line",
                    "evidence": f"the residual's position spectrum peaks at {pk['frequency']:.4g} cycles/{ctx.unit_pos} (period "
                                f"{period:.4g} {ctx.unit_pos}, {cycles:.1f} cycles over the travel), one sinusoid explaining "
                                f"{100 * pk['share']:.1f} % of the moving-sample residual variance"})
    return out


GRAVITY_PERIOD_BAND = 0.05


def _is_gravity_period(period: float) -> bool:
    """True if a rotary axis's position line of ``period`` [rad] is one cycle per revolution
    (within ``GRAVITY_PERIOD_BAND`` = 5 % of 2π): its columns ``sin, cos(2π·θ/period)`` are then
    gravity_imbalance's ``sin θ, cos θ`` to within the record's resolution of the period, and the
    kind is gravity_imbalance, never position_periodic (the band of the candidate filter that was
    already there; a line needs ≥ 2 cycles over the travel, so this arises only over ≥ 2 turns)."""
    return abs(period - 2 * math.pi) < GRAVITY_PERIOD_BAND * 2 * math.pi


def _b_gravity(ctx: _Ctx) -> list[dict[str, Any]]:
    if ctx.linear or ctx.cur.spec.gravity or ctx.span < GRAVITY_MIN_SPAN_RAD:
        return []
    f = fit_model(ctx.prep, dataclasses.replace(ctx.cur.spec.copy(), gravity=True))
    return [{"kind": "gravity_imbalance", "slot": None, "fit": f, "group": "slow",
             "evidence": f"the axis moved over {math.degrees(ctx.span):.0f}° (≥ {math.degrees(GRAVITY_MIN_SPAN_RAD):.0f}°), "
                         "enough to separate A·sin(θ+φ) from the offset"}]


def _b_time_periodic(ctx: _Ctx) -> list[dict[str, Any]]:
    out = []
    spec = ctx.cur.spec
    ts = res.time_spectrum(ctx.prep.t_dec, ctx.cur.residual)
    T = float(ctx.prep.t_dec[-1] - ctx.prep.t_dec[0])
    for pk in res.find_peaks(ts, n_peaks=ctx.cfg.n_peaks):
        f0 = pk["frequency"]
        if f0 * T < res.MIN_CYCLES:
            continue
        if any(abs(f0 - f) < 0.02 * f for f in spec.time_frequencies):
            continue
        new = spec.copy()
        new.time_frequencies.append(f0)
        slot = len(new.time_frequencies) - 1
        i = _hyper_index(new, "time_frequencies", slot)
        f = fit_model(ctx.prep, new, free=[i], rel_bounds={i: min(0.25, 2.0 / (f0 * T))})
        out.append({"kind": "time_periodic", "slot": slot, "fit": f, "group": "line",
                    "motion_share": motion_share(ctx.prep, f.spec.time_frequencies[slot]),
                    "evidence": f"the residual's time spectrum peaks at {f0:.4g} Hz, one sinusoid explaining "
                                f"{100 * pk['share']:.1f} % of the residual variance"})
    return out


_BUILDERS: dict[str, Callable[[_Ctx], list[dict[str, Any]]]] = {
    "asymmetric_friction": _b_asymmetric,
    "position_periodic": _b_position_periodic,
    "gravity_imbalance": _b_gravity,
    "presliding": _b_presliding,
    "backlash": _b_backlash,
    "time_periodic": _b_time_periodic,
}
if set(_BUILDERS) != set(EFFECT_KINDS):  # pragma: no cover - a new kind needs its candidate builder
    raise ImportError(f"plant.calibration.loop has candidate builders for {sorted(_BUILDERS)}, "
                      f"the plant.effects registry has {sorted(EFFECT_KINDS)}")


#: Time constants tried for the friction drift's exponential shape, as fractions of the record
#: (:func:`plant.calibration.fit.drift_shape`), and ``None``, the quadratic of sessions ≤ 47 (a slow
#: warm-up's limit). From one cross-validation block (1/8 of the record, ``LoopConfig.k_folds``): a
#: faster decay lies in the first block, where held-out prediction can only extrapolate it and where
#: a start-up transient (the axis and the loop settling, the decimation filter's edge) looks the same —
#: on fixed seeds 55 and 56 and on a linear ramp the in-sample minimum sat there (session 48). Up to
#: 1.5 records; spaced about 1.6× apart, then refined between neighbours. The heating shape
#: (session 49) uses the same grid without ``None``.
DRIFT_TIME_CONSTANTS = (0.125, 0.2, 0.33, 0.55, 0.9, 1.5, None)


#: The friction drift's shape families tried by :func:`_drift_candidate`: ``"warm-up"``, functions of
#: the record's time (τ with τ² or exp(−τ/λ), session 48), and ``"heating"``, lags of the friction
#: power (:func:`plant.calibration.fit.heating_shapes`, session 49).
DRIFT_SHAPES = ("warm-up", "heating")


def _drift_candidate(ctx: _Ctx) -> FitResult:
    """The friction drift added to the current model (``ctx.cur``), fitted.

    Warm-up shape (session 48): the second time column's time constant is the one of
    :data:`DRIFT_TIME_CONSTANTS` with the least in-sample residual, refined between its grid
    neighbours; the exponential is kept only where it predicts held-out time blocks better than the
    quadratic (``None``) at the run's family-wise level, else the quadratic is used.

    Heating shape (session 49): the same grid and refinement for the lags of the friction power. It
    replaces the warm-up only where its in-sample residual is smaller and it predicts held-out time
    blocks better, at the run's family-wise level, than the warm-up *with a free function of the
    speed beside it* (the ``velocity_function`` nuisance): a lag of ``|dq|`` shorter than the
    record's legs is a function of the speed, and without this test it stands in for the model's own
    velocity error on clean records (fixed seeds 41, 42; docs/calibration.md, "Session 49"); on a
    periodic motion the rival also holds the phase guard's lines (a function of the motion's phase).
    """
    def fit_at(lam: float | None, heating: bool = False) -> FitResult:
        new = ctx.cur.spec.copy()
        new.nuisance.append("friction_drift")
        new.drift_time_constant = lam
        new.drift_heating = heating
        return fit_model(ctx.prep, new, refine=False)

    def refined(lams: tuple[float | None, ...], heating: bool,
                fits: dict[float | None, FitResult] | None = None) -> tuple[FitResult, dict]:
        # ``fits``: the grid's fits when the caller already has them (the heating's, compared first)
        fits = fits if fits is not None else {lam: fit_at(lam, heating) for lam in lams}
        lam_b = min(fits, key=lambda k: fits[k].rss)
        best = fits[lam_b]
        if lam_b is not None:
            # refined between the grid's neighbours (log scale): the drift's shape left by a time constant
            # off by the grid's step is a smooth residual other terms would take (session 48)
            j = DRIFT_TIME_CONSTANTS.index(lam_b)
            lo = math.log(DRIFT_TIME_CONSTANTS[max(j - 1, 0)])
            hi = math.log(DRIFT_TIME_CONSTANTS[j + 1] if DRIFT_TIME_CONSTANTS[j + 1] is not None else 2 * lam_b)
            r = optimize.minimize_scalar(lambda x: fit_at(math.exp(x), heating).rss, bounds=(lo, hi),
                                         method="bounded", options={"xatol": 0.01})
            f = fit_at(math.exp(float(r.x)), heating)
            if f.rss < best.rss:
                best = f
        return best, fits

    z_need = single_test_z(ctx.cfg)
    best, fits = refined(DRIFT_TIME_CONSTANTS, False)
    if best.spec.drift_time_constant is not None:
        # the exponential replaces the quadratic only on the loop's own evidence: it predicts held-out
        # time blocks better than the quadratic, at the run's family-wise level (as the Stribeck term,
        # select_stribeck). Where the drift is weak the in-sample residual hardly depends on the time
        # constant, and its minimum sits on a start-up transient (fixed seeds 55, 56; session 48).
        quad = fits[None]
        gain, z = cv_compare(cv_losses(ctx.prep, quad.spec, ctx.cfg.k_folds),
                             cv_losses(ctx.prep, best.spec, ctx.cfg.k_folds))
        if not predicts(gain, z, z_need):
            best = quad
    lams = tuple(lam for lam in DRIFT_TIME_CONSTANTS if lam is not None)
    if "heating" in DRIFT_SHAPES and lams:
        grid = {lam: fit_at(lam, True) for lam in lams}
        if min(f.rss for f in grid.values()) < best.rss:
            heat, _ = refined(lams, True, grid)
            rival = best.spec.copy()
            rival.nuisance.append("velocity_function")
            if ctx.guard is not None:
                # on a periodic motion a lag of |dq| is also a function of the motion's phase (its rise and
                # fall lag the speed's): the rival holds the phase guard's lines too (fixed seed 41, a sinusoid)
                rival.nuisance.append("phase_function")
                rival.phase_hz, rival.phase_harmonics, rival.phase_odd = ctx.guard
            gain, z = cv_compare(cv_losses(ctx.prep, rival, ctx.cfg.k_folds),
                                 cv_losses(ctx.prep, heat.spec, ctx.cfg.k_folds))
            if predicts(gain, z, z_need):
                best = heat
    return fit_model(ctx.prep, best.spec)


def _out_of_library(ctx: _Ctx) -> list[dict[str, Any]]:
    out = []
    for name, evidence in (("friction_drift", "friction levels that change over the record (warm-up, temperature)"),
                           ("delay", "a shift between the torque and the measured motion")):
        if name in ctx.cur.spec.nuisance:
            continue
        if name == "friction_drift":
            fit = _drift_candidate(ctx)
        else:
            new = ctx.cur.spec.copy()
            new.nuisance.append(name)
            fit = fit_model(ctx.prep, new)
        out.append({"kind": name, "slot": None, "fit": fit, "group": "out-of-library",
                    "evidence": evidence})
    return out


#: Two line candidates of one kind whose refined lines lie closer than this many of the record's
#: frequency bins (one bin: one cycle over the record's time for a time line, over the travel for a
#: position line) are reported as the same line (session 56; report only, every candidate is still
#: tested and counted in the significance level). Why half a bin: lines closer than one bin cannot be
#: resolved by the record (the Rayleigh limit of the spectrum that proposed them); each peak's
#: refinement is free over ±2 bins, so the main lobe and a side lobe of one line end on the same
#: minimum. Session 55 tried dropping such duplicates before the test (one candidate, a smaller
#: level): on never-used records it gained none and lost one, because two refinements 0.12 bins apart
#: can still get different phase-guard verdicts (docs/calibration.md, "Session 55").
SAME_LINE_BINS = 0.5


def _line_of(ctx: _Ctx, c: dict[str, Any]) -> tuple[float, float, str] | None:
    """A line candidate's refined line: frequency, the record's bin for it and the unit — [Hz] and
    1/T for a time line, [cycles/rad or cycles/m] and 1/travel for a position line; None for every
    other kind."""
    spec = c["fit"].spec
    if c["kind"] == "time_periodic":
        t = ctx.prep.t_dec
        return float(spec.time_frequencies[c["slot"]]), 1.0 / float(t[-1] - t[0]), "Hz"
    if c["kind"] == "position_periodic":
        return 1.0 / float(spec.position_periods[c["slot"]]), 1.0 / ctx.span, f"cycles/{ctx.unit_pos}"
    return None


def _lines_described(ctx: _Ctx, cands: list[dict[str, Any]]) -> None:
    """Give every line candidate its refined line, ``line`` = ``{"frequency", "unit"}``, and one that
    lies within :data:`SAME_LINE_BINS` bins of a candidate of its kind with a lower in-sample rss
    ``same_line_as`` = ``{"frequency", "bins_apart"}`` (that candidate's line). Report only: the loop
    tests every candidate as before.

    Until session 56 a rejected line said neither which line it was nor that two or three spectrum
    peaks (one line's main lobe and side lobes) had been refined onto it: used independent 22031
    reported the same refusal of a time line three times."""
    seen: dict[str, list[float]] = {}
    for c in sorted(cands, key=lambda c: c["fit"].rss):
        ln = _line_of(ctx, c)
        if ln is None:
            continue
        f, b, unit = ln
        c["line"] = {"frequency": f, "unit": unit}
        same = next((g for g in seen.get(c["kind"], []) if abs(g - f) < SAME_LINE_BINS * b), None)
        if same is not None:
            c["same_line_as"] = {"frequency": same, "bins_apart": abs(same - f) / b}
        seen.setdefault(c["kind"], []).append(f)


def _candidates(ctx: _Ctx) -> list[dict[str, Any]]:
    out = []
    for kind in ctx.cfg.kinds:
        out += _BUILDERS[kind](ctx)
    return out + _out_of_library(ctx)


def motion_share(prep: Prepared, f_hz: float) -> float:
    """Largest share of variance a sinusoid at ``f_hz`` explains in the motion itself
    (velocity, |velocity| or sign of velocity), 0..1. A time-periodic residual at such a
    frequency cannot be told apart from a velocity-dependent model error."""
    t = prep.t_dec - prep.t_dec[0]
    X = np.column_stack([np.sin(2 * np.pi * f_hz * t), np.cos(2 * np.pi * f_hz * t), np.ones_like(t)])
    best = 0.0
    for sig in (prep.dq_dec, np.abs(prep.dq_dec), np.sign(prep.dq_dec)):
        s0 = sig - sig.mean()
        v = float(s0 @ s0)
        if v <= 0:
            continue
        coef, *_ = np.linalg.lstsq(X, sig, rcond=None)
        r = sig - X @ coef
        best = max(best, 1.0 - float(r @ r) / v)
    return best


#: A motion is periodic when K harmonics of one fundamental (K from ``PHASE_HARMONICS`` to
#: :data:`PERIODIC_MAX_HARMONICS`) explain at least this share of the velocity's variance (assumed: on
#: the benchmark's fixed seeds sinusoid trajectories reach ≥ 0.987 with 3 harmonics, square-ish
#: back-and-forth sweeps 0.925–0.930 with 3, staircases and tracking runs far less, EMPS 0.936 with 3;
#: fixed before any calibration was run, docs/calibration.md, session 18).
PERIODIC_MIN_SHARE = 0.95
#: At most this many harmonics of the fundamental are used to recognise a periodic motion (and then
#: in the phase guard). Why 15 (session 25, fixed before its runs from the physics, not from a score):
#: the limit of a back-and-forth sweep at constant speed is a square-wave velocity, whose odd
#: harmonics carry ``8/π²·Σ 1/k²`` of its variance — K = 3: 90.1 %, 5: 93.3 %, 7: 94.96 %, 9: 96.0 %;
#: finite accelerations only lower the high harmonics, so a sweep needs at most 9. The cap leaves
#: room above 9 for sweeps with dwells at the ends or unequal speeds (pulse-like velocity, even
#: harmonics) and stops there, so that "periodic" keeps meaning a few lines of one fundamental and
#: not a free Fourier series of the record.
PERIODIC_MAX_HARMONICS = 15
#: ... and when the record holds at least this many of its periods (fewer: every smooth function of
#: time would count as "periodic").
PERIODIC_MIN_CYCLES = 3.0
#: ... or, for a motion that :data:`~plant.calibration.fit.PHASE_HARMONICS` (3) harmonics describe (a
#: sinusoid), at least this many (session 47). Seven columns over two periods are far from "every smooth
#: function of time" (a staircase, a tracking run or legs at different speeds need many more; a
#: back-and-forth sweep with short ramps can reach 95 % with 3 and is then guarded, as it is from 3
#: cycles on), while on a sinusoid of 2–3 cycles without the phase guard a time line at the motion's own frequency or
#: a gravity stood in for the model's error along the motion (blind 15285: a 15 N·m line on a clean record,
#: the viscous coefficient ×11 beside it; 10 of the 42 used blind sinusoids of 2–3 cycles, 14620–15339,
#: named a kind they did not hide).
PERIODIC_MIN_CYCLES_SINUSOID = 2.0


def _harmonic_shares(t: np.ndarray, v: np.ndarray, var: float, f: float, k_max: int, odd: bool = False) -> np.ndarray:
    """Share of the variance ``var`` of ``v`` (0..1) explained by a constant and the harmonics
    1..K of ``f`` [Hz] on the times ``t``, for K = 1..``k_max`` (entry K − 1); with ``odd`` the odd
    harmonics 1, 3, …, K only, for odd K ≤ ``k_max`` (entry (K − 1)/2; :func:`half_wave_fundamental`).

    The columns X = [1, sin, cos of k·2π f t, k = 1..k_max], in that order, are orthogonalised in
    that order: with the Cholesky factor L of the Gram matrix XᵀX, the entries of L⁻¹Xᵀv are the
    coordinates of v on the orthonormal basis of a QR of X, so the first 2K + 1 of them squared are
    what the first K harmonics explain. Until session 30 this was that QR (Q formed explicitly);
    the Gram route gives the same shares to ≈ 1e-13 (harmonics over ≥ 3 cycles are close to
    orthogonal, so squaring the condition number costs nothing) in a quarter of the time, and
    :func:`periodic_motion` calls it a few hundred times per record (a third of a 10⁶-sample
    record's calibration)."""
    ks = range(1, k_max + 1, 2 if odd else 1)
    X = np.empty((t.size, 2 * len(ks) + 1))
    X[:, 0] = 1.0
    for j, k in enumerate(ks, start=1):
        X[:, 2 * j - 1] = np.sin(2 * np.pi * k * f * t)
        X[:, 2 * j] = np.cos(2 * np.pi * k * f * t)
    try:
        c2 = linalg.solve_triangular(np.linalg.cholesky(X.T @ X), X.T @ v, lower=True) ** 2
    except np.linalg.LinAlgError:
        # a singular Gram matrix (columns that coincide: never for ≥ 3 cycles below a quarter of the
        # sampling rate, as periodic_motion asks): one least-squares fit per K, the definition
        out = []
        for j in range(1, len(ks) + 1):
            coef, *_ = np.linalg.lstsq(X[:, : 2 * j + 1], v, rcond=None)
            r = v - X[:, : 2 * j + 1] @ coef
            out.append(1.0 - float(r @ r) / var)
        return np.array(out)
    vv = float(v @ v)
    return np.array([1.0 - (vv - float(c2[: 2 * j + 1].sum())) / var for j in range(1, len(ks) + 1)])


def _velocity_rows(prep: Prepared) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, float]:
    """The rows the periodic-motion functions read: evenly spaced, unfiltered full-rate rows, one per
    decimation step (the decimated time base ``t_dec`` passed through the decimation filter, which
    bends it at the ends). Returns (times from 0 [s], velocity, velocity minus its mean, its sum of
    squares, the rows' spacing [s]); shapes (n,)."""
    step = max(int(prep.decim), 1)
    t = prep.t[::step] - prep.t[0]
    v = prep.dq[::step]
    v0 = v - v.mean()
    return t, v, v0, float(v0 @ v0), prep.dt_s * step


def _guard_harmonics_max(dt_rows_s: float, f_hz: float) -> int:
    """The most harmonics of ``f_hz`` the phase guard may use on rows ``dt_rows_s`` apart: below a
    quarter of their sampling rate, within ``PHASE_HARMONICS`` … :data:`PERIODIC_MAX_HARMONICS`."""
    return max(PHASE_HARMONICS, min(PERIODIC_MAX_HARMONICS, int(0.25 / (dt_rows_s * f_hz))))


def periodic_motion(prep: Prepared) -> tuple[float | None, float, int]:
    """The fundamental [Hz] of a periodic motion, or None; the share of the velocity's variance its
    harmonics explain (0..1); and the number K of harmonics that reach it.

    A motion is periodic when K harmonics of one fundamental explain ≥ :data:`PERIODIC_MIN_SHARE` of
    the velocity's variance with ≥ ``PERIODIC_MIN_CYCLES`` cycles in the record — or, when that search
    finds none, when ``PHASE_HARMONICS`` harmonics do so with ≥ :data:`PERIODIC_MIN_CYCLES_SINUSOID`
    cycles (a sinusoid of 2–3 cycles; session 47, docs/calibration.md). K is the smallest
    number from ``PHASE_HARMONICS`` (3, session 18's guard) to :data:`PERIODIC_MAX_HARMONICS` (15)
    for which a fundamental reaches that share, and the fundamental is the best one at that K: a
    sinusoid needs 3 (as before session 25), a back-and-forth sweep, whose velocity is close to a
    square wave, needs up to 9 (session 25). K starts at 3, so a motion periodic with 3 harmonics is
    found at the same fundamental as before. Harmonics beyond the third are kept below a quarter of the
    sampling rate of the rows used (half their Nyquist frequency, well inside the fit's decimation
    pass band).

    The fundamental is refined on a ±3 % grid around the full-rate velocity spectrum's strongest peak
    (with at least ``PERIODIC_MIN_CYCLES`` cycles in the record) and around half and a third of it
    (the peak may be a harmonic), and, since a bin (1/T) is wider than ±3 % when the record holds
    fewer than about 17 cycles, on ± one bin around each of them (41 points, then 21 around the
    best of those at the most harmonics; session 25); the share is measured on the full-rate velocity taken every
    decimation step (evenly spaced, standstills included). The best share can fall on a
    sub-harmonic: on a sinusoid of ≥ 6 cycles f/2 explains all that f does (its 2nd harmonic is f),
    so the fundamental reported (and the guard's lines) can be f/2, f, 3f/2. Taking the shortest
    period instead was measured and not kept (docs/calibration.md, "Session 33"). On a periodic
    motion position, velocity, acceleration and the motion's own time lines are functions of one
    phase, so a smooth term can stand in for the model's error (see :func:`run_loop`, the phase guard).

    Returns
    -------
    (float or None, float, int)
        The fundamental [Hz] when the share reaches :data:`PERIODIC_MIN_SHARE`, else None; the share
        at that fundamental and K (if not periodic: the best share found with
        :data:`PERIODIC_MAX_HARMONICS` harmonics or as many as fit below the limit); K (if not
        periodic: ``PHASE_HARMONICS``).
    """
    t, v, v0, var, dt_rows = _velocity_rows(prep)
    n = t.size
    if n < 16 or t[-1] <= 0:
        return None, 0.0, PHASE_HARMONICS
    if var <= 0:
        return None, 0.0, PHASE_HARMONICS
    f, share, k = _periodic_search(t, v, v0, var, dt_rows, PERIODIC_MIN_CYCLES, PERIODIC_MAX_HARMONICS)
    if f is None:
        # a sinusoid-like motion (PHASE_HARMONICS harmonics suffice) from fewer cycles (session 47)
        f2, share2, k2 = _periodic_search(t, v, v0, var, dt_rows, PERIODIC_MIN_CYCLES_SINUSOID, PHASE_HARMONICS)
        if f2 is not None:
            return f2, share2, k2
    return f, share, k


def _periodic_search(t: np.ndarray, v: np.ndarray, v0: np.ndarray, var: float, dt_rows: float, cycles: float,
                     k_top: int) -> tuple[float | None, float, int]:
    """:func:`periodic_motion`'s search with at least ``cycles`` periods in the record and at most
    ``k_top`` harmonics (same returns)."""
    n = t.size
    fs = 1.0 / dt_rows
    freqs = np.fft.rfftfreq(n, d=dt_rows)
    spec = np.abs(np.fft.rfft(v0 * np.hanning(n)))
    # (3 % slack: a record of exactly ``cycles`` periods is periodic; the grid below is ±3 % wide)
    min_cycles = 0.97 * cycles
    ok = freqs >= min_cycles / t[-1]
    if not ok.any():
        return None, 0.0, PHASE_HARMONICS
    f_peak = float(freqs[int(np.argmax(np.where(ok, spec, 0.0)))])
    grid: list[tuple[float, np.ndarray]] = []

    def add(fs_hz) -> None:
        for f in fs_hz:
            if f * t[-1] < min_cycles:
                continue
            k_max = max(PHASE_HARMONICS, min(PERIODIC_MAX_HARMONICS, int(0.25 * fs / f)))
            grid.append((float(f), _harmonic_shares(t, v, var, float(f), k_max)))

    bin_hz = 1.0 / t[-1]
    for div in (1.0, 2.0, 3.0):
        f_c = f_peak / div
        add(np.linspace(0.97 * f_c, 1.03 * f_c, 61))
        # With few cycles a bin (1/T) is wider than ±3 %: the fundamental lies within one bin of
        # the strongest one (session 25, second change). A coarse pass over ±1 bin, then a fine
        # pass over ± one coarse step around its best fundamental at the most harmonics.
        lo = max(f_c - bin_hz, min_cycles / t[-1])
        hi = f_c + bin_hz
        if hi <= lo:
            continue
        n0 = len(grid)
        add(np.linspace(lo, hi, 41))
        coarse = grid[n0:]
        if coarse:
            f_best = max(coarse, key=lambda g: g[1][-1])[0]
            d = (hi - lo) / 40
            add(np.linspace(f_best - d, f_best + d, 21))
    if not grid:
        return None, 0.0, PHASE_HARMONICS
    for k in range(PHASE_HARMONICS, k_top + 1):
        best_f, best_share = None, 0.0
        for f, sh in grid:
            if sh.size >= k and sh[k - 1] > best_share:
                best_f, best_share = f, float(sh[k - 1])
        if best_f is not None and best_share >= PERIODIC_MIN_SHARE:
            return best_f, best_share, k
    return None, max(float(sh[-1]) for _, sh in grid), PHASE_HARMONICS


def periodic_motion_hz(prep: Prepared) -> tuple[float | None, float]:
    """The fundamental [Hz] of a periodic motion, or None, and the share of the velocity's variance
    its harmonics explain (0..1): the first two of :func:`periodic_motion`."""
    f, share, _ = periodic_motion(prep)
    return f, share


def motion_harmonics(prep: Prepared, f_hz: float) -> int:
    """The number K of harmonics of the fundamental ``f_hz`` that the phase guard uses: the smallest
    K from ``PHASE_HARMONICS`` to :data:`PERIODIC_MAX_HARMONICS` (beyond the third, below a quarter of
    the rows' sampling rate) whose share of the velocity's variance reaches :data:`PERIODIC_MIN_SHARE`, as
    :func:`periodic_motion` finds it; else ``PHASE_HARMONICS``. The model's error along the phase is
    a function of the motion's state, at the least of its velocity: as many harmonics as the
    velocity needs are needed to describe it (session 25)."""
    t, v, _, var, dt_rows = _velocity_rows(prep)
    k_max = _guard_harmonics_max(dt_rows, f_hz)
    if var <= 0:
        return PHASE_HARMONICS
    sh = _harmonic_shares(t, v, var, f_hz, k_max)
    for k in range(PHASE_HARMONICS, k_max + 1):
        if sh[k - 1] >= PERIODIC_MIN_SHARE:
            return k
    return PHASE_HARMONICS


def half_wave_fundamental(prep: Prepared, f_hz: float) -> tuple[float, int, float] | None:
    """The motion's own fundamental [Hz], the number K of its harmonics the phase guard holds and the
    share of the velocity's variance its odd harmonics 1, 3, …, K explain, when the periodic motion of
    fundamental ``f_hz`` (:func:`periodic_motion`) is half-wave symmetric; else None.

    Why (session 42). The rigid model is symmetric in the motion: inertia, viscous, Coulomb and
    Stribeck friction change sign with the state ``(q − q_c, dq, ddq)``; its only even term, the
    offset, is a constant. A half-wave symmetric motion — a sinusoid, a back-and-forth sweep with
    equal speeds and dwells — maps that state onto its negative half a period later. So any error of
    that model along the motion (a friction shape it lacks, an inertia biased by the encoder's noise
    fed back through the velocity loop, sessions 14 and 16; a compliance, a delay, a symmetric play
    or bristle) changes sign every half period: its Fourier series holds the odd harmonics of the
    motion only. The even harmonics of the residual can come only from what breaks the symmetry —
    gravity off its zero, direction-dependent friction, a position ripple, a disturbance: library
    kinds, which compete for them by held-out prediction. The guard of session 18 held every
    harmonic 1..K and so refused a gravity whose even part (``A·sin(θ_c + φ)·cos(θ − θ_c)``, the
    ``cos 2ωt`` line) it could not take from the rigid model's error anyway: on the never-used
    records of sessions 40–41, 20 of the 33 gravity records on sinusoids were missed or named as
    asymmetric friction. Gravity centred on its zero is odd in ``θ − θ_c`` and still refused: on a
    sinusoid it is the inertia and the third harmonic, which the rigid model's error can be.

    The motion's own fundamental may be a multiple m = 1, 2, 3 of ``f_hz`` (:func:`periodic_motion`
    can report a sub-harmonic: on a sinusoid of ≥ 6 cycles f/2 explains all that f does); the first m
    whose odd harmonics 1..K (K ≤ :data:`PERIODIC_MAX_HARMONICS`, below a quarter of the rows'
    sampling rate) explain ≥ :data:`PERIODIC_MIN_SHARE` of the velocity's variance — the same
    definition as "periodic" — is taken, with the smallest such K, at least ``PHASE_HARMONICS``. On
    the same rows as :func:`periodic_motion`.

    Returns
    -------
    (float, int, float) or None
        (fundamental [Hz], K, share 0..1) or None when no m's odd harmonics reach the share (the
        velocity has even harmonics: unequal speeds or dwells; the guard then holds every harmonic).
    """
    t, v, _, var, dt_rows = _velocity_rows(prep)
    if var <= 0 or not f_hz > 0:
        return None
    for m in (1, 2, 3):
        f = m * f_hz
        sh = _harmonic_shares(t, v, var, f, _guard_harmonics_max(dt_rows, f), odd=True)
        for j, share in enumerate(sh):
            if share >= PERIODIC_MIN_SHARE:
                return f, max(2 * j + 1, PHASE_HARMONICS), float(share)
    return None


#: |correlation| of gravity's odd column with the acceleration's above which the report says the two
#: trade against each other (assumed: 0.9, "nearly collinear"; on a sinusoid it is ≈ 1, on the
#: benchmark's back-and-forth sweeps far less — report text only, no decision reads it)
GRAVITY_INERTIA_CORRELATION = 0.9


def _gravity_on_symmetric_motion(prep: Prepared, fit: FitResult) -> str:
    """The evidence sentence for a gravity accepted on a half-wave symmetric motion (session 42): the
    part even about the motion's centre ``θc`` (``A·sin(θc + φ)`` [N·m]) is what no error of the
    symmetric model can take; the odd part ``A·cos(θc + φ)`` is said to trade against the inertia
    when its column ``sin(θ − θc)`` is correlated with the acceleration's by at least
    :data:`GRAVITY_INERTIA_CORRELATION` (on a sinusoid ``θ̈ = −ω²(θ − θc)``). Empty otherwise."""
    names, X = design(prep, fit.spec)
    if not {"grav_sin", "grav_cos", "inertia"} <= set(names):
        return ""
    coef = dict(zip(fit.names, fit.coef))
    s, c = float(coef["grav_sin"]), float(coef["grav_cos"])
    qc = 0.5 * (float(np.max(prep.q)) + float(np.min(prep.q)))
    even = s * math.sin(qc) + c * math.cos(qc)
    odd = s * math.cos(qc) - c * math.sin(qc)
    col = X[:, names.index("grav_sin")] * math.cos(qc) - X[:, names.index("grav_cos")] * math.sin(qc)
    acc = X[:, names.index("inertia")]
    if np.std(col) == 0 or np.std(acc) == 0:
        return ""
    r = abs(float(np.corrcoef(col, acc)[0, 1]))
    text = (f" On this half-wave symmetric motion its part even about the motion's centre (θc = {qc:.4g} rad), "
            f"A·sin(θc+φ) = {even:.4g} N·m at acceptance, is what no error of the symmetric model can take")
    if r >= GRAVITY_INERTIA_CORRELATION:
        text += (f"; its odd part, A·cos(θc+φ) = {odd:.4g} N·m at acceptance, has a column correlated {r:.3f} with the acceleration's, so it "
                 "and the inertia trade against each other and A and φ rest on the record's small departures from that "
                 "shape (session 42: A within 30 % on 15 of 20 such benchmark records, up to 2.4× off on the others). "
                 "A record that also holds a non-sinusoidal motion (a staircase, a sweep) separates them")
    return text + "."


def time_shift_diagnostic(prep: Prepared, fit: FitResult) -> dict[str, float]:
    """How much of the residual a time shift between torque and motion explains.

    Regresses the residual on ``dŷ/dt`` (first-order Taylor term of ``ŷ(t + τ)``): ``τ`` is the
    shift, ``share_pct`` the share of the residual variance it explains.
    """
    yhat = fit.yhat
    if yhat.size < 10:
        return {"shift_s": 0.0, "share_pct": 0.0}
    d = np.gradient(yhat, prep.t_dec)
    den = float(d @ d)
    r = fit.residual
    if den <= 0 or float(r @ r) <= 0:
        return {"shift_s": 0.0, "share_pct": 0.0}
    tau = float(r @ d) / den
    r2 = r - tau * d
    return {"shift_s": -tau, "share_pct": 100.0 * (1.0 - float(r2 @ r2) / float(r @ r))}


def _unexplained(prep: Prepared, fit: FitResult, cfg: LoopConfig, linear: bool, ool: list[dict[str, Any]],
                 alias: tuple[list[tuple[float, float]], float | None] = ([], None)) -> list[dict[str, Any]]:
    """The ``unexplained`` entries; ``alias`` is :func:`constant_speed_runs`'s result (runs, quantum), computed
    once by :func:`run_loop`, for the notes of peaks at an alias of the count rate."""
    out = [dict(x) for x in ool]
    j = fit.param("inertia") if "inertia" in fit.names else 0.0
    mov = res.moving_mask(prep.dq_dec)
    speed_typ = typical_speed(prep)
    q = prep.position_resolution

    def peak_note(share: float, var: float, w: float) -> str:
        # the peak's amplitude (one sinusoid holding ``share`` of ``var``) as a motion, in quanta
        if not (j > 0 and q > 0 and w > 0):
            return "a spectral peak no library effect predicts on held-out blocks"
        x = line_motion_quanta(math.sqrt(2.0 * share * var), j, w, q)
        if x < MIN_TRANSITION_COUNTS:
            return (f"a spectral peak whose amplitude is the inertial torque of a motion of {x:.2g} position quanta "
                    f"(< {MIN_TRANSITION_COUNTS:g}): as far as this record can tell, structure of the measurement chain "
                    "(the velocity loop acting on quantised counts), not a torque on the axis")
        return "a spectral peak no library effect predicts on held-out blocks"

    runs, q_exact = alias
    fs_log = 1.0 / prep.dt_s

    def alias_note(f_hz: float | None, nu: float | None) -> str | None:
        # a peak at an alias of the count rate on most of the constant-speed time (_count_alias)
        if not runs or q_exact is None:
            return None
        share, worst = count_alias_share(f_hz, nu, runs, q_exact, fs_log)
        if share < 0.5:
            return None
        return (f"a spectral peak within one frequency bin (≤ {worst:.3g} Hz off, on {100 * share:.0f} % of the "
                f"constant-speed time) {COUNT_ALIAS_WHAT.format(fs=fs_log)}: structure of the measurement chain (the "
                "velocity loop's quantised feedback sampled by the log without an anti-alias filter), not a torque on "
                "the axis")

    ps = res.position_spectrum(prep.q_dec, prep.dq_dec, fit.residual)
    var_mov = float(np.var(fit.residual[mov])) if mov.any() else float(np.var(fit.residual))
    for pk in res.find_peaks(ps, n_peaks=3, min_share=cfg.min_share_pct / 100, fap_max=1e-3):
        out.append({"domain": "position", "frequency": pk["frequency"], "share_pct": 100 * pk["share"],
                    "unit": f"cycles/{'m' if linear else 'rad'}",
                    "note": alias_note(None, pk["frequency"])
                    or peak_note(pk["share"], var_mov, 2.0 * math.pi * pk["frequency"] * speed_typ)})
    ts = res.time_spectrum(prep.t_dec, fit.residual)
    var_all = float(np.var(fit.residual))
    for pk in res.find_peaks(ts, n_peaks=3, min_share=cfg.min_share_pct / 100, fap_max=1e-3):
        item = {"domain": "time", "frequency": pk["frequency"], "share_pct": 100 * pk["share"], "unit": "Hz",
                "note": alias_note(pk["frequency"], None) or peak_note(pk["share"], var_all, 2.0 * math.pi * pk["frequency"])}
        ms = motion_share(prep, pk["frequency"])
        if ms >= 0.02:
            item["note"] = (f"coincides with a line of the motion itself ({100 * ms:.0f} % of the velocity signal's variance): "
                            "likely a velocity-dependent model error rather than a disturbance")
        out.append(item)
    if "delay" not in fit.spec.nuisance:
        lag = time_shift_diagnostic(prep, fit)
        if lag["share_pct"] >= cfg.min_share_pct * 3 and abs(lag["shift_s"]) >= 2 * prep.dt_s:
            out.append({"domain": "time", "frequency": None, "share_pct": lag["share_pct"], "unit": "Hz",
                        "note": (f"the residual follows the time derivative of the model's torque (best-fitting shift "
                                 f"{1e3 * abs(lag['shift_s']):.1f} ms, a first-order estimate): a delay between the torque and "
                                 "the measured motion, which no effect in the library describes")})
    return out


def _delay_s(fit: FitResult) -> float | None:
    """The shift the delay description stands for: its jerk coefficient over the inertia (torque =
    J·ddq(t + τ) ≈ J·ddq + J·τ·jerk), seconds; None without the inertia."""
    if "nz_delay_jerk" not in fit.names or "inertia" not in fit.names:
        return None
    j = float(fit.coef[fit.names.index("inertia")])
    return float(fit.coef[fit.names.index("nz_delay_jerk")]) / j if j > 0 else None


def _drift_time_constant_s(prep: Prepared, fit: FitResult) -> float | None:
    """The friction drift's time constant in seconds (its fraction of the record times the record's
    duration, :func:`plant.calibration.fit.drift_shape`); None for the quadratic shape."""
    lam = fit.spec.drift_time_constant
    return None if lam is None else lam * float(prep.t[-1] - prep.t[0])


def _ool_entry(kind: str, share: float, gain: float, z: float, shift_s: float | None = None,
               held_out: tuple[float, float] | None = None, time_constant_s: float | None = None,
               heating: bool = False) -> dict[str, Any]:
    if kind == "friction_drift":
        shape = ("τ, τ²" if time_constant_s is None
                 else f"lags of |dq| and dq² (the friction power), T ≈ {time_constant_s:.3g} s, the heating's time constant"
                 if heating else f"τ and exp(−t/T), T ≈ {time_constant_s:.3g} s, the warm-up's time constant")
        entry = {"domain": "time", "frequency": None, "share_pct": share, "unit": "Hz", "kind": "friction_drift",
                 "note": (f"friction levels drift over the record (Coulomb/viscous terms × {shape}; cross-validated gain "
                          f"{gain:.1f} %, z = {z:.1f}): a warm-up or temperature effect, outside the library")}
        if time_constant_s is not None:
            entry["time_constant_s"] = time_constant_s
            entry["shape"] = "heating" if heating else "warm-up"
        return entry
    note = (f"the residual follows the jerk, i.e. the torque is shifted against the motion (cross-validated gain "
            f"{gain:.1f} %, z = {z:.1f}"
            + (f"; ≈ {1e3 * shift_s:.2f} ms, jerk coefficient / inertia, a first-order estimate" if shift_s is not None else "")
            + "): a delay outside the library")
    if held_out is not None:
        note += (f"; a property of the drive, not of the record, so it is kept in the held-out prediction "
                 f"(rms {held_out[0]:.4g} → {held_out[1]:.4g}) but not written to the plant file")
    return {"domain": "time", "frequency": None, "share_pct": share, "unit": "Hz", "kind": "delay", "note": note,
            **({"shift_s": shift_s} if shift_s is not None else {})}


def _gain_with_nuisance(prep: Prepared, cur: ModelSpec, cand: ModelSpec, nuisance: str, k_folds: int,
                        phase_hz: float | None = None, phase_harmonics: int = PHASE_HARMONICS,
                        phase_odd: bool = False, units: np.ndarray | None = None) -> tuple[float, float]:
    """:func:`cv_compare` of the current model and the candidate, both with the nuisance description
    ``nuisance`` added (and ``phase_hz``, ``phase_harmonics``, ``phase_odd`` set for ``"phase_function"``;
    ``units`` as for :func:`cv_compare`): (gain %, z)."""
    return cv_compare(*_losses_with_nuisance(prep, cur, cand, nuisance, k_folds, phase_hz, phase_harmonics, phase_odd),
                      units=units)


def _losses_with_nuisance(prep: Prepared, cur: ModelSpec, cand: ModelSpec, nuisance: str, k_folds: int,
                          phase_hz: float | None = None, phase_harmonics: int = PHASE_HARMONICS,
                          phase_odd: bool = False) -> tuple[CVErrors, CVErrors]:
    """:func:`cv_losses` of the current model and the candidate, both with ``nuisance`` added (see
    :func:`_gain_with_nuisance`)."""
    s0, s1 = cur.copy(), cand.copy()
    for sp in (s0, s1):
        sp.nuisance.append(nuisance)
        if phase_hz is not None:
            sp.phase_hz = phase_hz
            sp.phase_harmonics = phase_harmonics
            sp.phase_odd = phase_odd
    return cv_losses(prep, s0, k_folds), cv_losses(prep, s1, k_folds)


def _not_friction_along_travel(prep: Prepared, cur: ModelSpec, c: dict[str, Any], zc: float,
                               cfg: LoopConfig) -> str | None:
    """None if the time line ``c`` still predicts held-out blocks at the run's level ``zc`` with a
    friction level that varies along the travel in both models, else why not (session 39).

    A friction level that depends on the axis angle (a bearing whose normal load changes with the
    attitude, seal or cable drag) is direction-odd torque ``sign(dq)·g(q)``. On a slow run the
    position moves nearly linearly in time, so ``g(q)`` is a slow function of time and a time line
    at a low frequency takes it (blind records with load-dependent friction: a line of
    0.035–0.067 Hz named on 6 of 12 never-used records, session 38). The test puts the Coulomb
    column times hinges in the position (:func:`plant.calibration.fit.design_columns`,
    ``"friction_along_travel"``) into both models, as the velocity-function and phase tests do for
    their alternatives: a real disturbance of many cycles over the travel keeps its gain; one that
    the record cannot tell from such a friction does not, and its structure stays in
    ``unexplained``. Cost: on a record that moves one way only, a slow real time line (fewer
    cycles than the hinges can follow) is refused too — there the record cannot tell time from
    position. The comparison uses only the held-out rows that neither model extrapolates to
    (:func:`hidden_extrapolation`); with fewer than 125 such rows (5 batches of the rank test) the
    test is not made and the line is not refused: no evidence against it."""
    l0, l1 = _losses_with_nuisance(prep, cur, c["fit"].spec, "friction_along_travel", cfg.k_folds)
    # only rows where neither model extrapolates its hinges: a held-out block at positions the
    # other blocks did not visit (each leg of a tracking run at its own angle) is predicted by
    # neither, and the difference of two wild extrapolations says nothing about the line
    use = ~(l0.extrapolated | l1.extrapolated)
    if int(use.sum()) < 5 * 25:
        c["travel_friction_note"] = ("The test against a friction level that varies along the travel was not made: "
                                     "the position hinges are extrapolated on nearly every held-out row.")
        return None
    g, z = cv_compare(np.asarray(l0)[use], np.asarray(l1)[use])
    c["travel_friction_note"] = (f"It still predicts with a friction level that varies along the travel in both models "
                                 f"(gain {g:.1f} %, z = {z:.1f}): not friction that depends on the axis angle.")
    if predicts(g, z, zc):
        return None
    return (f"with a friction level that varies along the travel (Coulomb column × hinges in the position) in both "
            f"models the line no longer predicts (gain {g:.2f} %, z = {z:.1f}, needs z ≥ {zc:.2f}): this record cannot "
            "tell it from friction that depends on the axis angle")


#: ``undecided`` entries' reasons: too few reversals for a reversal effect (:func:`min_events`), or a
#: periodic motion on which the candidate predicts only as well as a function of its phase (session 33)
UNDECIDED_REVERSALS = "reversals"
UNDECIDED_PERIODIC = "periodic"


def _undecided_periodic(undecided: dict[str, dict[str, Any]], c: dict[str, Any], step: int, why: str) -> None:
    """Record a candidate that predicts held-out blocks (it passed the rule) but that the phase guard
    refuses: the record cannot tell it from the model's error along a periodic motion's phase, so
    it is not decided by this record (issue 7: "an effect the record does not excite is not
    found" — the report says so per record, as it does for too few reversals). The best gain of a
    kind is kept."""
    if c["cv_gain_pct"] > undecided.get(c["kind"], {}).get("cv_gain_pct", 0.0):
        undecided[c["kind"]] = {"kind": c["kind"], "reason": UNDECIDED_PERIODIC, "step": step,
                                "cv_gain_pct": c["cv_gain_pct"], "cv_z": c["cv_z"], "why": why,
                                **{k: c[k] for k in ("line",) if k in c}}


def _static_refusals(c: dict[str, Any], cur: FitResult, cfg: LoopConfig, prep: Prepared, dwell_swings: np.ndarray,
                     speed_typ: float, span: float, alias_runs: list[tuple[float, float]],
                     alias_q: float | None) -> list[tuple[str, str]]:
    """Every rule of the record's geometry that refuses candidate ``c``, in the order the loop applies
    them (session 52): the share floor (:func:`_below_share_floor`), the resolution limits
    (:func:`_resolved`, :func:`_line_resolved`), the stick at the reversals (:func:`_sticks_at_reversals`,
    reversal kinds), the count-rate alias (:func:`_count_alias`) — library kinds only — and, for every
    kind, the inertia (:func:`_replaces_inertia`), and for asymmetric friction a direction's friction level
    (:func:`_removes_friction`, session 58); each by its name in :data:`GEOMETRY_RULES`.

    These rules read only the candidate's fit and figures the run computed once (no refit), so all of
    them are evaluated for every candidate with a positive held-out gain (one without has nothing to
    obstruct; :func:`run_loop` does not call this for it); the first is the refusal's reason, exactly as when they
    were chained, and ``rejected``'s ``also`` lists the others. A user then sees every obstacle at
    once: a backlash refused both for its share and for a width under the resolution needs a finer
    encoder, not a longer record. The tests that cost refits (the Stribeck term, the declared spring,
    the viscous-split twin, the velocity-function, travel and phase guards, the held-out record) run
    only while no rule has refused the candidate, as before.

    Parameters
    ----------
    c : dict
        The candidate (``kind``, ``group``, ``slot``, ``fit``, ``cv_gain_pct`` [%], ``cv_z``).
    cur : FitResult
        The current model.
    cfg : LoopConfig
    prep : Prepared
    dwell_swings : numpy.ndarray, shape (n,)
        Torque swings at the reversals' turning points [N·m or N]
        (:func:`plant.calibration.residuals.reversal_dwell_swings`).
    speed_typ : float
        The record's typical moving speed [rad/s or m/s] (:func:`typical_speed`).
    span : float
        The moving travel [rad or m].
    alias_runs, alias_q
        :func:`constant_speed_runs`' runs and quantum.

    Returns
    -------
    list of (str, str)
        ``(rule, reason)`` for each rule that refuses the candidate (rule from :data:`GEOMETRY_RULES`),
        empty if none does.
    """
    out: list[tuple[str, str | None]] = []
    if c["kind"] in EFFECT_KINDS:
        out += [("share_floor", _below_share_floor(c, cfg)),
                ("resolution", _resolved(c["fit"], prep.position_resolution)),
                ("stick_at_reversals", _sticks_at_reversals(c["fit"], dwell_swings, prep.position_resolution)
                 if c["group"] == "reversal" else None),
                ("line_resolution", _line_resolved(c["fit"], c["kind"], c["slot"], prep.position_resolution, speed_typ,
                                                   cfg.drive_periods, span)),
                ("count_alias", _count_alias(c["fit"], c["kind"], c["slot"], alias_runs, alias_q, 1.0 / prep.dt_s))]
    out.append(("inertia", _replaces_inertia(cur, c["fit"])))
    if c["kind"] == "asymmetric_friction":
        out.append(("friction_bound", _removes_friction(cur, c["fit"])))
    return [(rule, why) for rule, why in out if why]


#: The rules of :func:`_static_refusals`, in the order the loop applies them; ``rejected[i]["rules"]`` names
#: those that refuse a candidate (session 53: the names let a tool count refusals without matching words).
GEOMETRY_RULES = ("share_floor", "resolution", "stick_at_reversals", "line_resolution", "count_alias", "inertia",
                  "friction_bound")


def _told_from_other_reversal_kind(c: dict[str, Any], cands: list[dict[str, Any]], units: np.ndarray, zc: float,
                                   n_rev: int) -> str | None:
    """None if the reversal candidate ``c``, whose test rests on the reversals' units (:func:`unit_compare`;
    the rank test alone does not pass it), predicts held-out blocks significantly better than the step's
    candidate of the other reversal kind, at the run's level ``zc`` on the same test (:func:`cv_compare`
    with ``units``); else why not (session 61).

    On a record with fewer reversals than the rank test can pass on, a pre-sliding and a backlash both
    describe the same few transients: tested one by one each can pass, and the larger gain would pick a
    name the record has not chosen (used blind 27719 and independent 27682: a gap named pre-sliding at
    80.4 % against the backlash's 82.6 %, at 20.1 % against 20.7 %). The head-to-head comparison is the
    issue's "effects that compete for the same residual are fitted against each other": a name needs it
    separated, else the kind is reported undecided. With no candidate of the other kind at the step (it
    is already in the model, or not tried) there is nothing to separate.
    """
    other = next((o for o in cands if o["group"] == "reversal" and o["kind"] != c["kind"] and "loss" in o), None)
    if other is None:
        return None
    g, z = cv_compare(other["loss"], c["loss"], units=units)
    c["against_other_reversal"] = {"kind": other["kind"], "gain_pct": g, "z": z}
    if predicts(g, z, zc):
        return None
    return (f"on this record's {n_rev} reversals it is not told from {other['kind']} (gain {other['cv_gain_pct']:.2f} %): "
            f"head to head on the reversals' units it predicts better by {g:.2f} %, z = {z:.1f} (needs > 0 and z ≥ {zc:.2f}); "
            "both describe the same few transients")


def _evaluate(prep: Prepared, c: dict[str, Any], loss_cur: np.ndarray, cfg: LoopConfig,
              units: np.ndarray | None = None) -> None:
    c["loss"] = cv_losses(prep, c["fit"].spec, cfg.k_folds)
    c["cv_gain_pct"], c["cv_z"] = cv_compare(loss_cur, c["loss"], units=units)
    if units is not None:
        c["unit_test"] = True
        c["rank_z"] = cv_compare(loss_cur, c["loss"])[1]


def run_loop(
    prep: Prepared,
    prep_val: Prepared | None = None,
    cfg: LoopConfig | None = None,
    linear: bool | None = None,
) -> LoopResult:
    """Run the whole calibration loop on a prepared record (optionally with a held-out one).

    Returns
    -------
    LoopResult
    """
    cfg = cfg or LoopConfig()
    linear = prep.record.linear if linear is None else linear
    log: list[str] = []
    base, stribeck = fit_baseline(prep, cfg)
    log.append(f"baseline: rms {base.rms:.4g}, rel. error {base.relative_error_pct:.3f} %, Stribeck: {stribeck.get('reason', '')}")
    if prep.hunting:
        log.append(f"hunting: the velocity hunts (stick-slip at one speed) on {len(prep.hunting)} stretch(es), left out of the fit "
                   "like rests: " + ", ".join(f"{a:.1f}-{b:.1f} s" for a, b in prep.hunting))
    cur = base
    val_cur = val_before = vb = None
    if prep_val is not None:
        vb = predict(prep_val, base)
        val_before = val_cur = float(np.sqrt(np.mean(vb[1] ** 2)))
    accepted: list[AcceptedEffect] = []
    rejected: list[dict[str, Any]] = []
    ool: list[dict[str, Any]] = []
    present: set[str] = set()
    mov = res.moving_mask(prep.dq_dec)
    span = float(np.ptp(prep.q_dec[mov])) if mov.any() else float(np.ptp(prep.q_dec))
    vmax = float(np.percentile(np.abs(prep.dq), 99))
    n_rev = res.count_reversals(prep.t_dec, prep.dq_dec)
    rev_units = reversal_units(prep)   # unit_compare's units, used on a step whose k_min exceeds n_rev
    dwell_swings = res.reversal_dwell_swings(prep)   # _sticks_at_reversals, once per run
    speed_typ = typical_speed(prep)
    undecided: dict[str, dict[str, Any]] = {}
    phase_hz, phase_share = periodic_motion_hz(prep)
    n_pos, n_neg = both_directions(prep)
    two_way = min(n_pos, n_neg) >= MIN_SAMPLES_PER_DIRECTION
    if not two_way:
        rejected.append({"kind": "asymmetric_friction", "step": 1, "cv_gain_pct": None, "cv_z": None, "explained_pct": None,
                         "reason": (f"not tried: the axis moves one way only ({n_pos} moving samples with w > 0, {n_neg} with "
                                    f"w < 0, moving meaning faster than {100 * res.MOVING_FRAC:.0f} % of the 95th-percentile speed; "
                                    f"{MIN_SAMPLES_PER_DIRECTION} needed on each side): the other direction's friction "
                                    "is not in the record"), "also": [], "rules": []})
    # the guard's harmonics: as many as the motion's velocity needs (session 25), at least PHASE_HARMONICS
    phase_k = motion_harmonics(prep, phase_hz) if phase_hz is not None else PHASE_HARMONICS
    # the guard's lines: the odd harmonics of the motion's own fundamental on a half-wave symmetric motion
    # (session 42), else every harmonic 1..phase_k of phase_hz
    half_wave = half_wave_fundamental(prep, phase_hz) if (cfg.odd_phase_guard and phase_hz is not None) else None
    guard_hz, guard_k = (half_wave[0], half_wave[1]) if half_wave is not None else (phase_hz, phase_k)
    t_span = float(prep.t[-1] - prep.t[0])
    # the count-alias test's runs and quantum, once per run (_count_alias)
    alias_runs, alias_q = constant_speed_runs(prep) if cfg.count_alias_guard else ([], None)
    if phase_hz is not None:
        # the lines themselves, so that a reader can check them against the motion: the fundamental can be a
        # sub-harmonic of the motion's own (session 33; periodic_motion's docstring)
        lines = ", ".join(f"{k * guard_hz:.4g}" for k in range(1, guard_k + 1, 2 if half_wave is not None else 1))
        log.append(f"periodic motion: {phase_k} harmonics of {phase_hz:.5g} Hz explain {100 * phase_share:.1f} % of the "
                   f"velocity; smooth position and time terms must also predict with them ({lines} Hz) in both models "
                   "(phase guard)")
        if half_wave is not None:
            log.append(f"the motion is half-wave symmetric (the odd harmonics 1..{guard_k} of {guard_hz:.5g} Hz explain "
                       f"{100 * half_wave[2]:.1f} % of its velocity): the guard holds those, the only lines a model symmetric "
                       "in the motion can err by; even harmonics are left to the symmetry-breaking kinds (session 42)")
    step = 0
    settled = False   # the last step found nothing more to add (its candidates were tested against the final model)
    while len(accepted) < cfg.max_effects and step < cfg.max_effects + 2:
        step += 1
        # a periodic entry describes the candidates against the current model: each step replaces them
        for kind in [k for k, u in undecided.items() if u["reason"] == UNDECIDED_PERIODIC]:
            del undecided[kind]
        ctx = _Ctx(prep, cur, present, cfg, linear, span, vmax, two_way,
                   guard=(guard_hz, guard_k, half_wave is not None) if phase_hz is not None else None)
        cands = _candidates(ctx)
        if not cands:
            break
        loss_cur = cv_losses(prep, cur.spec, cfg.k_folds)
        spring_cache = ctx.spring_cache   # the declared spring's model, once per step (_beats_gear_spring)
        stribeck_cache: dict[str, Any] = {}   # the current model with the Stribeck term, once per step (_beats_stribeck)
        # Bonferroni over every candidate test the run may make: family-wise error family_alpha
        zc = z_critical(cfg.family_alpha, len(cands) * cfg.max_effects)
        k_min = min_events(cfg.family_alpha, len(cands) * cfg.max_effects)
        # fewer counted reversals than a sign test can pass on: a reversal candidate's tests are made on the
        # per-reversal units' loss ratios too, beside the rank test's batches (session 61, unit_compare)
        units = rev_units if (rev_units is not None and n_rev < k_min) else None
        zc_rank_alone = z_critical(cfg.family_alpha, 2 * len(cands) * cfg.max_effects)   # the rank test at the doubled count
        for c in cands:
            _evaluate(prep, c, loss_cur, cfg, units if c["group"] == "reversal" else None)
            c["explained_pct"] = 100.0 * (cur.rss - c["fit"].rss) / cur.rss
            c["delta_bic"] = delta_bic(cur.rss, c["fit"].rss, c["fit"].n_params - cur.n_params, cur.n_eff)
        _lines_described(ctx, cands)
        cands.sort(key=lambda c: -c["cv_gain_pct"])
        log.append(f"step {step} candidates (cross-validated gain %, z): "
                   + "; ".join(f"{c['kind']} {c['cv_gain_pct']:.2f} % z={c['cv_z']:.1f}" for c in cands))
        passing = []
        for c in cands:
            why = None
            # every rule of the record's geometry that refuses a candidate with a gain, in the order they are
            # applied; the first is the reason, the others are reported beside it (session 52), by name too
            static = (_static_refusals(c, cur, cfg, prep, dwell_swings, speed_typ, span, alias_runs, alias_q)
                      if c["cv_gain_pct"] > 0 else [])
            if not predicts(c["cv_gain_pct"], c["cv_z"], zc):
                why = (f"does not predict held-out blocks better: gain {c['cv_gain_pct']:.2f} %, z = {c['cv_z']:.1f} "
                       f"(needs > 0 and z ≥ {zc:.2f})" if c["cv_gain_pct"] <= 0 else
                       # a positive mean gain that the rank test does not find in enough of the record's batches
                       # (session 52: "does not predict better" read as a contradiction beside a 20 % gain)
                       f"predicts held-out blocks better on average (gain {c['cv_gain_pct']:.2f} %) but not consistently "
                       f"enough along the record to be significant: z = {c['cv_z']:.1f} (needs z ≥ {zc:.2f}; the gain lies "
                       "in too few of the rank test's batches)" if not c.get("unit_test") else
                       # tested on its reversals' loss ratios too (session 61): neither test finds it consistent enough
                       f"predicts held-out blocks better on average (gain {c['cv_gain_pct']:.2f} %) but not consistently "
                       f"enough to be significant, along the record or over its {n_rev} reversals: z = {c['cv_z']:.1f} "
                       f"(needs z ≥ {zc:.2f}; the rank test, or Student's t on the reversals' held-out loss ratios, "
                       f"the smaller p doubled; the rank test needs at least {k_min} reversals when the gain lies at them)")
                if (c["group"] == "reversal" and c["cv_gain_pct"] > 0 and n_rev < k_min
                        and c["cv_gain_pct"] > undecided.get(c["kind"], {}).get("cv_gain_pct", 0.0)
                        and all(rule != "stick_at_reversals" for rule, _ in static)):
                    undecided[c["kind"]] = {"kind": c["kind"], "reason": UNDECIDED_REVERSALS, "step": step,
                                            "cv_gain_pct": c["cv_gain_pct"], "cv_z": c["cv_z"],
                                            "n_reversals": n_rev, "min_reversals": k_min, "unit_test": bool(c.get("unit_test")),
                                            "advised_reversals": rank_batches_needed(zc, rank_batches(prep.y_dec.size))}
            if why is None and static:
                why = static[0][1]
            if why is None and c["kind"] == "asymmetric_friction":
                why = _viscous_split_predicts(prep, c, zc, cfg)
            if why is None and c["group"] == "reversal" and cfg.gear_stiffness is not None:
                why = _beats_gear_spring(prep, cur, c, cfg, spring_cache, zc)
            if why is None and c["group"] == "reversal":
                why = _beats_stribeck(prep, cur, c, zc, cfg, stribeck_cache, units if c.get("unit_test") else None)
            if why is None and c["kind"] == "time_periodic" and c["motion_share"] >= 0.02:
                # the motion has a line here: must still predict with a flexible velocity function in both models
                g, z = _gain_with_nuisance(prep, cur.spec, c["fit"].spec, "velocity_function", cfg.k_folds)
                if not predicts(g, z, zc):
                    why = (f"the motion has a line at this frequency ({100 * c['motion_share']:.0f} % of the velocity signal) "
                           f"and with a flexible velocity function in the model the line no longer predicts (gain {g:.2f} %, "
                           f"z = {z:.1f}): a velocity-dependent model error, not a disturbance")
            if why is None and c["kind"] == "time_periodic" and cfg.travel_friction_guard:
                # must still predict with a friction level that varies along the travel in both models
                why = _not_friction_along_travel(prep, cur.spec, c, zc, cfg)
            if why is None and phase_hz is not None and c["kind"] == "time_periodic":
                # within one frequency bin (1/T, Rayleigh) of a guarded harmonic: not resolvable from it
                f_c = c["fit"].spec.time_frequencies[c["slot"]]
                k_near = max(1, min(phase_k, round(f_c / phase_hz)))
                near_any = abs(f_c - k_near * phase_hz) < 1.0 / t_span
                if half_wave is not None:
                    # a half-wave symmetric motion (session 56): the model's own error along it holds only the odd
                    # harmonics of the motion's fundamental (session 42), so only those are lines this record cannot
                    # tell a disturbance from; near an even harmonic the line goes on to the phase guard's test and
                    # competes with the symmetry-breaking kinds, as gravity's even part does
                    k_odd = min(range(1, guard_k + 1, 2), key=lambda k: abs(f_c - k * guard_hz))
                    if abs(f_c - k_odd * guard_hz) < 1.0 / t_span:
                        why = (f"the motion is periodic and half-wave symmetric (the odd harmonics 1..{guard_k} of "
                               f"{guard_hz:.4g} Hz explain {100 * half_wave[2]:.1f} % of the velocity) and the line at "
                               f"{f_c:.5g} Hz lies within one frequency bin (1/T = {1.0 / t_span:.3g} Hz) of its harmonic "
                               f"{k_odd}: this record cannot resolve it from a function of the motion's phase")
                        _undecided_periodic(undecided, c, step, why)
                    elif near_any:
                        log.append(f"step {step}: the time line at {f_c:.5g} Hz lies within one frequency bin of the "
                                   f"motion's line at {k_near * phase_hz:.5g} Hz, not an odd harmonic of its fundamental "
                                   f"{guard_hz:.4g} Hz: tested by the phase guard instead (session 56)")
                elif near_any:
                    why = (f"the motion is periodic ({phase_k} harmonics of {phase_hz:.4g} Hz explain "
                           f"{100 * phase_share:.1f} % of the velocity) and the line at {f_c:.5g} Hz lies within one frequency "
                           f"bin (1/T = {1.0 / t_span:.3g} Hz) of its harmonic {k_near}: this record cannot resolve it from "
                           "a function of the motion's phase")
                    _undecided_periodic(undecided, c, step, why)
            if why is None and phase_hz is not None and c["kind"] in PHASE_GUARDED:
                # a periodic motion: must still predict with any smooth function of its phase in both models
                g, z = _gain_with_nuisance(prep, cur.spec, c["fit"].spec, "phase_function", cfg.k_folds, phase_hz=guard_hz,
                                      phase_harmonics=guard_k, phase_odd=half_wave is not None,
                                      units=units if c.get("unit_test") else None)
                c["phase_gain"] = (g, z)
                if not predicts(g, z, zc):
                    held = (f"its odd harmonics 1..{guard_k} of {guard_hz:.4g} Hz (half-wave symmetric)" if half_wave is not None
                            else "those harmonics")
                    why = (f"the motion is periodic ({phase_k} harmonics of {phase_hz:.4g} Hz explain "
                           f"{100 * phase_share:.1f} % of the velocity) and with {held} in the model the term no "
                           f"longer predicts (gain {g:.2f} %, z = {z:.1f}): on this record it cannot be told apart from a "
                           "smooth error of the model along the motion's phase")
                    _undecided_periodic(undecided, c, step, why)
            if why is None and prep_val is not None and (c["kind"] in EFFECT_KINDS or c["kind"] in TRANSFERABLE):
                _, vr = predict(prep_val, c["fit"])
                c["val_rms"] = float(np.sqrt(np.mean(vr**2)))
                if not c["val_rms"] < val_cur:
                    why = f"held-out record: rms {val_cur:.4g} → {c['val_rms']:.4g} (does not fall)"
            if why is None and c.get("unit_test") and not c["rank_z"] >= zc_rank_alone:
                # on the reversals' own test (session 61) the other reversal kind must lose head to head: a few
                # reversals' transients fit a bristle and a gap alike, and a name the record cannot choose is undecided
                why = _told_from_other_reversal_kind(c, cands, units, zc, n_rev)
                if why is not None:
                    undecided[c["kind"]] = {"kind": c["kind"], "reason": UNDECIDED_REVERSALS, "step": step,
                                            "cv_gain_pct": c["cv_gain_pct"], "cv_z": c["cv_z"], "n_reversals": n_rev,
                                            "min_reversals": k_min, "unit_test": True, "not_told": why,
                                            "advised_reversals": rank_batches_needed(zc, rank_batches(prep.y_dec.size))}
            if why is not None:
                rejected.append({"kind": c["kind"], "step": step, "cv_gain_pct": c["cv_gain_pct"], "cv_z": c["cv_z"],
                                 "explained_pct": c["explained_pct"], "reason": why,
                                 "also": [r for _, r in static if r != why], "rules": [rule for rule, _ in static],
                                 **{k: c[k] for k in ("line", "same_line_as") if k in c}})
                continue
            passing.append(c)
        if not passing:
            log.append(f"step {step}: no candidate passes")
            settled = True
            break
        lib = [c for c in passing if c["kind"] in EFFECT_KINDS]
        if half_wave is not None and len(lib) > 1:
            # a half-wave symmetric motion: the library candidates compete on their gain beyond the motion's
            # odd harmonics (session 42) — the part of a gain that lies in them may be the model's own error
            # (gravity's odd part shares the inertia's column on a sinusoid), the rest is each candidate's
            # claim to the symmetry-breaking residual
            for c in lib:
                if "phase_gain" not in c:
                    c["phase_gain"] = _gain_with_nuisance(prep, cur.spec, c["fit"].spec, "phase_function", cfg.k_folds,
                                                          phase_hz=guard_hz, phase_harmonics=guard_k, phase_odd=True)
            lib.sort(key=lambda c: -c["phase_gain"][0])
            log.append(f"step {step}: half-wave symmetric motion, the library candidates ranked by their gain beyond its odd "
                       "harmonics: " + "; ".join(f"{c['kind']} {c['phase_gain'][0]:.2f} % z={c['phase_gain'][1]:.1f}" for c in lib))
        chosen = passing[0] if passing[0]["kind"] in OUT_OF_LIBRARY or not lib else lib[0]
        if chosen["kind"] in OUT_OF_LIBRARY and lib:
            # library first: an out-of-library description wins only if it predicts significantly
            # better than the best library candidate (same test, same level)
            g, z = cv_compare(lib[0]["loss"], chosen["loss"])
            if not predicts(g, z, zc):
                log.append(f"step {step}: {chosen['kind']} not significantly better than {lib[0]['kind']} "
                           f"(gain {g:.2f} %, z = {z:.1f}): the library effect is taken")
                chosen = lib[0]
        if chosen["kind"] in EFFECT_KINDS:
            # joint refit of every nonlinear parameter within narrow windows
            spec = chosen["fit"].spec
            rel = {i: (0.02 if n in ("position_periods", "time_frequencies") else 0.2) for i, (n, _, _) in enumerate(spec.hyper())}
            joint = fit_model(prep, spec, rel_bounds=rel) if rel else chosen["fit"]
            if (joint.rss < chosen["fit"].rss and _resolved(joint, prep.position_resolution) is None
                    and _replaces_inertia(cur, joint) is None
                    and (linear or not any(map(_is_gravity_period, joint.spec.position_periods)))):
                chosen["fit"] = joint
        # the winner against each competitor that passed too, head to head on the same held-out blocks (session 52:
        # "won" by a larger gain says nothing of whether the record tells the two apart — independent seed 27's
        # pre-sliding beat its backlash by 0.45 % of a 6.8 % gain). Not on a half-wave symmetric motion's library
        # ranking, which is on the gains beyond the motion's odd harmonics (the note below gives those). Only between
        # two library kinds: a second slot of the same kind (another peak refined onto the same line) is the same
        # name, and an out-of-library description loses to a library kind unless it is significantly better (the
        # library-first comparison above), so "not separated" would only restate that rule (EMPS: the ripple and
        # the delay description, both kept in the end).
        by_gain = not (half_wave is not None and len(lib) > 1 and chosen is lib[0])
        comps = []
        for c in [c for c in cands if c is not chosen][:4]:
            x = {"kind": c["kind"], "cv_gain_pct": c["cv_gain_pct"], "cv_z": c["cv_z"], "passed": any(c is p for p in passing)}
            if (x["passed"] and by_gain and c["kind"] != chosen["kind"]   # another slot of the same kind is the same name
                    and c["kind"] in EFFECT_KINDS and chosen["kind"] in EFFECT_KINDS):
                g, z = cv_compare(c["loss"], chosen["loss"])
                x.update(head_to_head_gain_pct=g, head_to_head_z=z, separated=predicts(g, z, zc))
            comps.append(x)
        f = chosen["fit"]
        won = "; ".join(f"{x['kind']} {x['cv_gain_pct']:.1f} % (z = {x['cv_z']:.1f}"
                        + (f"; head to head the {chosen['kind']} predicts better by {x['head_to_head_gain_pct']:.1f} % "
                           f"(z = {x['head_to_head_z']:.1f})"
                           + ("" if x["separated"] else ", not significant: this record does not tell the two apart")
                           if "head_to_head_z" in x else "") + ")"
                        for x in comps if x["cv_gain_pct"] > 0 and x["passed"])
        # candidates with a larger or positive gain that a rule refused did not compete: say so
        # instead of listing them as beaten (session 28: blind-reading seed 42's report)
        out_of_play = "; ".join(f"{x['kind']} {x['cv_gain_pct']:.1f} % (z = {x['cv_z']:.1f})" for x in comps
                                if x["cv_gain_pct"] > 0 and not x["passed"])
        if chosen["kind"] in OUT_OF_LIBRARY:
            ool.append(_ool_entry(chosen["kind"], chosen["explained_pct"], chosen["cv_gain_pct"], chosen["cv_z"],
                                  _delay_s(f) if chosen["kind"] == "delay" else None,
                                  (val_cur, chosen["val_rms"]) if "val_rms" in chosen else None,
                                  _drift_time_constant_s(prep, f) if chosen["kind"] == "friction_drift" else None,
                                  f.spec.drift_heating))
            log.append(f"step {step}: out-of-library {chosen['kind']} wins (gain {chosen['cv_gain_pct']:.2f} %, z {chosen['cv_z']:.1f}); "
                       "kept in the working model only"
                       + (f" (and in the held-out prediction: rms {val_cur:.4g} → {chosen['val_rms']:.4g})"
                          if "val_rms" in chosen else ""))
            cur = f
            if "val_rms" in chosen:
                val_cur = chosen["val_rms"]
            continue
        symmetric_note = (_gravity_on_symmetric_motion(prep, f)
                          if (half_wave is not None and chosen["kind"] == "gravity_imbalance") else "")
        if half_wave is not None and len(lib) > 1 and chosen is lib[0]:
            symmetric_note += (" On this half-wave symmetric motion the library candidates competed on their gain beyond its odd "
                      "harmonics: " + "; ".join(f"{c['kind']} {c['phase_gain'][0]:.1f} % (z = {c['phase_gain'][1]:.1f})" for c in lib)
                      + ".")
        ev = (f"{chosen['evidence'][0].upper()}{chosen['evidence'][1:]}. Predicts held-out time blocks better: the "
              f"cross-validated mean squared error falls by {chosen['cv_gain_pct']:.1f} % (z = {chosen['cv_z']:.1f}); it explains "
              f"{chosen['explained_pct']:.1f} % of the residual variance."
              + (f" Won against: {won}." if won else "")
              + (f" Not in the competition (refused by a rule or not significant; see the rejected candidates): "
                 f"{out_of_play}." if out_of_play else "")
              + (f" It also predicts better than the declared gear spring alone (gain {chosen['gain_over_spring_pct']:.1f} %, z = {chosen['z_over_spring']:.1f}; a point estimate is the test here"
                 + (f"; the spring's Coulomb level started from the candidate's, {chosen['spring_seed']:.3g}, as the current "
                    "model's is 0" if "spring_seed" in chosen else "") + ")."
                 if "gain_over_spring_pct" in chosen else "")
              + (f" It still predicts with the Stribeck term ({chosen['stribeck_note']}) in both models (gain "
                 f"{chosen['gain_with_stribeck_pct']:.1f} %, z = {chosen['z_with_stribeck']:.1f}): a transition, not "
                 "low-speed friction." if "gain_with_stribeck_pct" in chosen else "")
              + (f" Its direction-dependent viscous friction predicts better than a symmetric one with the Coulomb level "
                 f"split (gain {chosen['gain_over_coulomb_split_pct']:.1f} %, z = {chosen['z_over_coulomb_split']:.1f})."
                 if "gain_over_coulomb_split_pct" in chosen else "")
              + (f" {chosen['travel_friction_note']}" if "travel_friction_note" in chosen else "")
              + symmetric_note)
        acc = AcceptedEffect(kind=chosen["kind"], slot=chosen["slot"], rms_after=f.rms, variance_explained_pct=chosen["explained_pct"],
                             delta_bic=chosen["delta_bic"], evidence=ev, val_rms_after=chosen.get("val_rms"),
                             cv_gain_pct=chosen["cv_gain_pct"], cv_z=chosen["cv_z"], competitors=comps)
        accepted.append(acc)
        present.add(chosen["kind"])
        log.append(f"step {step}: add {acc.kind} (gain {acc.cv_gain_pct:.2f} %, z {acc.cv_z:.1f}, explains {acc.variance_explained_pct:.2f} %)")
        cur = f
        if prep_val is not None:
            val_cur = chosen["val_rms"]
    # a kind named later is decided; once a reversal effect is named its competitors lost to it; a periodic
    # entry holds only if it was tested against the final model (the last step added nothing)
    und = sorted((u for u in undecided.values()
                  if u["kind"] not in present and not (u["kind"] in REVERSAL_KINDS and present & REVERSAL_KINDS)
                  and (settled or u["reason"] != UNDECIDED_PERIODIC)),
                 key=lambda u: -u["cv_gain_pct"])
    for u in und:
        if u["reason"] == UNDECIDED_REVERSALS:
            adv = u.get("advised_reversals")
            u["note"] = (f"predicts held-out blocks better by {u['cv_gain_pct']:.1f} % (z = {u['cv_z']:.1f}"
                         + (", Student's t on the loss ratios of its reversals, session 61" if u.get("unit_test") else "")
                         + f"), but the record has "
                         f"{u['n_reversals']} velocity reversal(s); a gain confined to the reversals needs at least "
                         f"{u['min_reversals']} to pass the rank test at all (k reversals that all improve give at best p = 2^-k)"
                         + (", and on these few the reversals' own test does not reach the run's level: they do not improve "
                            "by a consistent enough amount" if u.get("unit_test") else "")
                         + (f", and the rank test over the record's batches about {adv}, one per batch, where the batches "
                            f"without a reversal are no better than chance: not decided by this record — record at least "
                            f"{adv} reversals, spread over the record, to decide it" if adv is not None else
                            ", and the record is too short for the rank test to pass at all: not decided by this record — "
                            f"record a longer run with at least {u['min_reversals']} reversals spread over it to decide it"))
        else:
            u["note"] = (f"predicts held-out blocks better by {u['cv_gain_pct']:.1f} % (z = {u['cv_z']:.1f}), but {u['why']} — "
                         "not decided by this record: record it on a motion that is not periodic (a staircase, or sweeps "
                         "at different speeds) to decide it")
    vf = predict(prep_val, cur) if prep_val is not None else None
    vl = predict(prep_val, cur, library_only=True) if prep_val is not None else None
    return LoopResult(
        baseline=base, final=cur, accepted=accepted, rejected=rejected, unexplained=_unexplained(prep, cur, cfg, linear, ool, (alias_runs, alias_q)),
        stribeck=stribeck, val_rms_before=val_before,
        val_rms_after=float(np.sqrt(np.mean(vf[1] ** 2))) if vf is not None else None,
        val_rms_after_library=float(np.sqrt(np.mean(vl[1] ** 2))) if vl is not None else None,
        val_baseline=vb, val_final=vf, linear=linear, log=log, out_of_library=ool, undecided=und,
    )
