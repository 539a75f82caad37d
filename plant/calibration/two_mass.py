"""The backlash gap of a geared drive estimated with the load's inertia: a two-mass description.

The loop names backlash with a massless description of the drive (:func:`plant.calibration.fit.
geared_coulomb` inside a declared spring, or a play on the logged position): the load stops the
moment the motor stops pushing it. A real load has inertia. It is carried across the gap by its
own momentum, hits the other flank and rings on the gear spring, so the motion lost at a reversal
is not ``gap + 2Fc/K`` and the massless model splits it wrongly between the gap and the spring's
wind-up. On independent seed 33 (a 35 Hz drive, load 41 % of the inertia) the massless gap was
54 % narrow; with the true load inertia in an otherwise identical model the gap's residual
minimum moved to −15 %, while with the load inertia made 20 times smaller it stayed at −50 %
(docs/calibration.md, "Session 36").

This module refits the gap after the loop, with the motor-side record driving a simulated load:

* motor (logged) side: ``τ = J_m q̈ + τ_c + (other load torques of the fit, as linear columns)``;
* gear: ``τ_c = K (d ∓ gap/2) + c (q̇ − q̇_l)`` outside the dead zone ``|d| ≤ gap/2``
  (``d = q − q_l``), 0 inside; ``K`` declared by the engineer (``--gear-stiffness``);
* load: ``J_l q̈_l = τ_c − offset − F(q̇_l)``, ``F`` the fit's own friction (Coulomb and viscous
  per direction, the Stribeck excess; its levels refitted, below), sticking (Karnopp) while ``|τ_c − offset|`` is under the
  static level. Semi-implicit Euler with sub-steps ``h ≤ OMEGA_H/ω`` of the two-mass mode ``ω``, the
  logged position interpolated between samples by cubic Hermite polynomials (velocities by
  central differences).

The gap is fitted first alone (a grid, then a bounded scalar refinement), then together with two
scale factors on the load's friction — one on its Coulomb levels (and Stribeck excess), one on its
viscous coefficients (:func:`_joint_refit`, session 37): on a slow record the massless fit trades
Coulomb for viscous friction over its narrow speed range, and where the gap is a fraction of the
wind-up ``2Fc/K`` a small error of the level at rest moves the gap by several gaps (blind-generator
record 10760: Coulomb 0.53 for 0.72 N·m, the two-mass gap 141 % wide at the fit's friction, 0.1 %
after the joint refit). The load's share of the fitted inertia ``J_l/J`` and the gear's damping
ratio ``ζ`` (``c = 2ζ sqrt(K J_m J_l / J)``) are fixed at nominal values (:data:`NOMINAL_SHARE`,
:data:`NOMINAL_ZETA`): fitted, in session 36's first attempt, they absorbed other model errors on the
blind generator's drives and went to their bounds; the generator's true share and ζ do not move
the gaps that failed there (session 37's probes). The linear parameters (``J_m``, the offset, the
fit's periodic and nuisance columns) are solved inside each evaluation on the same decimated rows
as the loop.

The two-mass gap replaces the loop's only where the two-mass model predicts held-out blocks better
than the loop's final model (blocked cross-validation, the folds and comparison of
:func:`plant.calibration.loop.cv_losses` / :func:`plant.calibration.loop.cv_compare`; a positive
gain, as :func:`plant.calibration.loop._beats_gear_spring`: the effect is already named, only its
size is estimated). The named effects never change.

The same description also compares, inside the loop, a gap with a compliant mode where the
massless backlash candidate loses to the massless declared spring (:func:`gap_against_compliance`,
session 38). From session 38 to 56 a gap that won there was named; since session 57 the answer is
reported in the candidate's refusal only (a gap is one more way to fit a compliant mode's ringing;
docs/calibration.md, "Session 57, second change"), so no named effect changes here.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
from scipy import optimize

from plant.calibration.fit import FitResult, Prepared, _solve, design_columns
from plant.calibration.loop import (MIN_TRANSITION_COUNTS, _coulomb, cv_compare, cv_losses, cv_losses_xy,
                                    check_stiffness)

#: The load's share of the fitted inertia ``J_l/J``, fixed (assumed: the record seldom pins it — session
#: 36's first attempt fitted it and it absorbed other model errors, going to its bounds on blind
#: drives; the even split is the middle of the possible range and gives the drive's lowest mode
#: ``sqrt(K/J)/π``, the bound the loop's band rule uses, plant.calibration.loop.spring_mode_floor_hz).
NOMINAL_SHARE = 0.5
#: The gear's damping ratio ζ, fixed (assumed: 0.1, the lower end of the 0.1–0.2 mesh damping
#: ratios usually cited for spur gears, Kasuba & Evans 1981; fitted, it absorbed model errors as the
#: share did).
NOMINAL_ZETA = 0.1
#: Gap grid: points per factor-of-16 span around the loop's gap (9 points: a factor √2 apart).
GAP_GRID_POINTS = 9
#: The gap is searched within the loop's gap divided and multiplied by this factor (assumed: the
#: massless description errs by the wind-up, of the order of the gap itself; session 36 measured
#: −54 % to +12 % on the fixed seeds).
GAP_SPAN = 4.0
#: Largest sub-step count per logged sample; a stiffer drive is refused (the description would cost
#: more than the whole loop; assumed, never reached on the benchmark: at most a few tens).
MAX_SUBSTEPS = 2000
#: Sub-step bound ``h·ω`` of the semi-implicit integrator (measured, tests/test_calibration_two_mass.py:
#: a driven load at 2–25 Hz logged at 200 Hz–2 kHz is within 1.8 % of the closed form at 0.04; with
#: linear instead of cubic interpolation between samples and 0.2 it was 14 % off at 200 Hz).
OMEGA_H = 0.04

#: The gap's source in a report when this module's estimate is used.
GAP_TWO_MASS = "refitted with the load's inertia: a two-mass drive with the gap in its gear (two_mass_gap)"


def _gear(d, dd, k, c, gh):
    """Gear torque for the deflection ``d`` and its rate ``dd`` with a dead zone ``|d| ≤ gh``; with a
    gap a contact pushes, never pulls (the damper's share is clamped while the flanks separate).
    Without a gap (``gh == 0``) both flanks stay in contact: a linear spring and damper (the fit
    never reaches it: its gap search starts above the record's resolution)."""
    if gh <= 0.0:
        return k * d + c * dd
    if d > gh:
        return max(k * (d - gh) + c * dd, 0.0)
    if d < -gh:
        return min(k * (d + gh) + c * dd, 0.0)
    return 0.0


def _load_sim(q, dt, nsub, jl, k, c, gh, fcp, fcn, fvp, fvn, dfs, vs, off):  # pragma: no cover - compiled
    """Gear torque [N·m or N] at each logged sample, shape (N,), the load driven by the logged ``q``.

    Per sub-step the gear torque is evaluated with the motor and load at the same instant (the
    sub-step's start), then the load's velocity and angle are advanced (semi-implicit Euler); the
    output is the gear torque at the sample's instant."""
    n = q.size
    h = dt / nsub
    ql = q[0]
    wl = 0.0
    out = np.zeros(n)
    fs_p = fcp + dfs
    fs_n = fcn + dfs
    for i in range(1, n):
        # cubic Hermite interpolation of the motor between samples, velocities by central differences
        q0 = q[i - 1]
        q1 = q[i]
        v0 = (q1 - q[i - 2]) / (2.0 * dt) if i >= 2 else (q1 - q0) / dt
        v1 = (q[i + 1] - q0) / (2.0 * dt) if i + 1 < n else (q1 - q0) / dt
        for s in range(nsub):
            u = s / nsub
            qm = (2 * u**3 - 3 * u**2 + 1) * q0 + (u**3 - 2 * u**2 + u) * dt * v0 + (3 * u**2 - 2 * u**3) * q1 \
                + (u**3 - u**2) * dt * v1
            wm = ((6 * u**2 - 6 * u) * (q0 - q1)) / dt + (3 * u**2 - 4 * u + 1) * v0 + (3 * u**2 - 2 * u) * v1
            tc = _gear(qm - ql, wm - wl, k, c, gh)
            drive = tc - off
            if wl == 0.0:        # stuck: friction balances the drive up to the static level
                if drive > fs_p:
                    fr = fs_p
                elif drive < -fs_n:
                    fr = -fs_n
                else:
                    fr = drive
            elif wl > 0.0:
                fr = fcp + dfs * math.exp(-(wl / vs) ** 2) + fvp * wl
            else:
                fr = -fcn - dfs * math.exp(-(wl / vs) ** 2) + fvn * wl
            wn = wl + h * (drive - fr) / jl
            if wl != 0.0 and wn * wl < 0.0:   # friction stops the load, it cannot reverse it
                wn = 0.0
            wl = wn
            ql += h * wl
        out[i] = _gear(q1 - ql, v1 - wl, k, c, gh)
    return out


try:  # compiled when numba is there (the same code interpreted otherwise, ≈100× slower)
    from numba import njit as _njit

    _gear = _njit(cache=True)(_gear)
    _load_sim = _njit(cache=True)(_load_sim)
except ImportError:  # pragma: no cover
    pass


#: Columns of the fit that the load simulation replaces (its friction, the offset on the load) or
#: that the two-mass model renames (the inertia becomes the motor's ``J_m``).
_REPLACED = ("inertia", "viscous", "viscous_pos", "viscous_neg", "coulomb", "coulomb_pos", "coulomb_neg", "offset",
             "stribeck", "presliding_damping")


@dataclasses.dataclass
class LoadFriction:
    """The fit's friction as the load simulation uses it (all ≥ 0 except ``offset``) [N·m or N, N·m·s/rad or N·s/m]."""

    coulomb_pos: float
    coulomb_neg: float
    viscous_pos: float
    viscous_neg: float
    stribeck_excess: float
    stribeck_vs: float
    offset: float

    @classmethod
    def of(cls, fit: FitResult) -> "LoadFriction":
        """From a :class:`plant.calibration.fit.FitResult` (symmetric or per direction; the mean over
        the record's time when a friction drift is in the model, :func:`plant.calibration.loop._coulomb`)."""
        p = fit.params()
        if "coulomb" in p:
            fcp = fcn = _coulomb(fit)
        else:
            fcp, fcn = p["coulomb_pos"], p["coulomb_neg"]   # torque = coulomb_neg · min(c, 0): a level ≥ 0
        fvp, fvn = (p["viscous"], p["viscous"]) if "viscous" in p else (p["viscous_pos"], p["viscous_neg"])
        return cls(max(fcp, 0.0), max(fcn, 0.0), max(fvp, 0.0), max(fvn, 0.0), max(p.get("stribeck", 0.0), 0.0),
                   float(fit.spec.stribeck_vs or 1.0), float(p.get("offset", 0.0)))


def substeps(dt_s: float, stiffness: float, j_motor: float, j_load: float) -> int:
    """Sub-steps per logged sample for ``h·ω ≤`` :data:`OMEGA_H`, ``ω² = K (1/J_m + 1/J_l)``."""
    w = math.sqrt(stiffness * (1.0 / j_motor + 1.0 / j_load))
    return max(1, int(math.ceil(dt_s * w / OMEGA_H)))


class TwoMass:
    """The two-mass description of one record and fit (the linear columns built once).

    Parameters
    ----------
    prep : Prepared
    fit : FitResult
        The loop's final fit (its inertia, friction and other columns).
    stiffness : float
        Declared gear stiffness [N·m/rad or N/m].

    Raises
    ------
    ValueError
        ``stiffness`` is not a positive finite number, or the fit has no positive inertia.
    """

    def __init__(self, prep: Prepared, fit: FitResult, stiffness: float):
        check_stiffness(stiffness)
        self.prep, self.stiffness = prep, float(stiffness)
        self.inertia = fit.param("inertia")
        if not self.inertia > 0:
            raise ValueError(f"two_mass_gap: the fit's inertia must be positive, got {self.inertia!r}")
        self.friction = LoadFriction.of(fit)
        spec = dataclasses.replace(fit.spec.copy(), backlash_width=None, gear_stiffness=None, spring_coulomb=None,
                                   presliding_k=None)
        names, cols = design_columns(prep, spec)
        kept = [(n, c) for n, c in zip(names, cols) if n not in _REPLACED]
        self.names = ["inertia", "offset"] + [n for n, _ in kept]
        self.X = np.column_stack([prep.dec(prep.ddq), prep.dec(np.ones_like(prep.q))] + [prep.dec(c) for _, c in kept])
        self._q = np.ascontiguousarray(prep.q, dtype=np.float64)

    def gear_torque(self, share: float, zeta: float, gap: float) -> np.ndarray | None:
        """Full-rate gear torque, shape (N,) [N·m or N]; None where it needs more than
        :data:`MAX_SUBSTEPS` sub-steps per sample."""
        jl = share * self.inertia
        jm = self.inertia - jl
        c = 2.0 * zeta * math.sqrt(self.stiffness * jm * jl / self.inertia)
        n_sub = substeps(self.prep.dt_s, self.stiffness, jm, jl)
        if n_sub > MAX_SUBSTEPS:
            return None
        f = self.friction
        return _load_sim(self._q, float(self.prep.dt_s), n_sub, jl, self.stiffness, c, 0.5 * gap, f.coulomb_pos,
                         f.coulomb_neg, f.viscous_pos, f.viscous_neg, f.stribeck_excess, f.stribeck_vs, f.offset)

    def target(self, share: float, zeta: float, gap: float) -> np.ndarray | None:
        """Decimated torque minus the gear torque (what the linear columns must fit), shape (M,)."""
        tc = self.gear_torque(share, zeta, gap)
        return None if tc is None else self.prep.y_dec - self.prep.dec(tc)

    def residual(self, share: float, zeta: float, gap: float) -> np.ndarray | None:
        """Decimated residual, shape (M,), the linear parameters solved with their bounds."""
        y = self.target(share, zeta, gap)
        if y is None:
            return None
        _, r = _solve(self.X, y, self.names)
        return r


#: The load's Coulomb and viscous levels refitted with the gap (session 37; False gives session 36's
#: second attempt, the gap alone at the fit's friction).
JOINT_FRICTION = True
#: Bounds of the friction scale factors, ÷ and × this (assumed: the massless fit's levels are right
#: within a factor 4; on session 37's records the refit kept the Coulomb scale within 0.83–1.44 and
#: the viscous within 0.33–2.29).
FRICTION_SCALE_SPAN = 4.0
#: Largest number of load simulations of the joint refit (assumed: bounds the cost to ≈ 10 × the
#: gap-only refit; Nelder–Mead on 3 parameters converges in 60–150 on the benchmark's records).
JOINT_MAX_SIMULATIONS = 200


def _joint_refit(tm: "TwoMass", share: float, zeta: float, gap: float, g_lo: float,
                 g_hi: float) -> tuple[float, tuple[float, float]]:
    """The gap refitted with scale factors on the load's Coulomb levels (and Stribeck excess) and
    viscous coefficients: Nelder–Mead in log space from ``gap`` [rad or m] at the fit's friction, the
    gap within ``[g_lo, g_hi]``, the scales within ÷/× :data:`FRICTION_SCALE_SPAN`, at most
    :data:`JOINT_MAX_SIMULATIONS` simulations. Returns ``(gap, (coulomb_scale, viscous_scale))``;
    the start point when nothing lowers the rss. Leaves ``tm.friction`` at the refitted levels."""
    f0 = tm.friction
    span = math.log(FRICTION_SCALE_SPAN)

    def scaled(x) -> LoadFriction:
        sc, sv = math.exp(x[1]), math.exp(x[2])
        return dataclasses.replace(f0, coulomb_pos=f0.coulomb_pos * sc, coulomb_neg=f0.coulomb_neg * sc,
                                   stribeck_excess=f0.stribeck_excess * sc,
                                   viscous_pos=f0.viscous_pos * sv, viscous_neg=f0.viscous_neg * sv)

    def rss(x):
        tm.friction = scaled(x)
        try:
            r = tm.residual(share, zeta, float(math.exp(x[0])))
        finally:
            tm.friction = f0
        return math.inf if r is None else float(r @ r)

    x0 = np.array([math.log(gap), 0.0, 0.0])
    rss0 = rss(x0)
    sol = optimize.minimize(rss, x0, method="Nelder-Mead",
                            bounds=[(math.log(g_lo), math.log(g_hi)), (-span, span), (-span, span)],
                            options={"xatol": 1e-3, "fatol": 1e-6 * max(rss0, 1e-300), "maxfev": JOINT_MAX_SIMULATIONS,
                                     "initial_simplex": x0 + np.vstack([np.zeros(3), 0.2 * np.eye(3)])})
    if not sol.fun < rss0:
        return gap, (1.0, 1.0)
    tm.friction = scaled(sol.x)
    sc, sv = math.exp(sol.x[1]), math.exp(sol.x[2])
    return float(math.exp(sol.x[0])), (sc, sv)


def _best_gap(tm: "TwoMass", share: float, zeta: float, g_lo: float, g_hi: float, n: int,
              step: float) -> float | None:
    """The gap [rad or m] of least residual: the best of ``n`` log-spaced points from ``g_lo`` to
    ``g_hi``, refined by bounded Brent in log space within ``step`` (a log-gap distance, the grid's
    spacing) of it and within the grid's ends; None if the drive needs more than
    :data:`MAX_SUBSTEPS` sub-steps per sample at every grid point. Shared by :func:`two_mass_gap`
    and :func:`gap_against_compliance`."""
    best = None
    for g in np.geomspace(g_lo, g_hi, n):
        r = tm.residual(share, zeta, float(g))
        if r is not None and (best is None or float(r @ r) < best[0]):
            best = (float(r @ r), float(g))
    if best is None:
        return None

    def rss(x: float) -> float:
        r = tm.residual(share, zeta, float(math.exp(x)))
        return math.inf if r is None else float(r @ r)

    x_b = math.log(best[1])
    sol = optimize.minimize_scalar(rss, bounds=(max(math.log(g_lo), x_b - step), min(math.log(g_hi), x_b + step)),
                                   method="bounded", options={"xatol": 1e-3})
    return float(math.exp(sol.x)) if sol.fun <= best[0] else best[1]


def two_mass_gap(prep: Prepared, fit: FitResult, stiffness: float, gap0: float,
                 k_folds: int = 8) -> tuple[float | None, dict[str, Any]]:
    """The gap of a geared drive refitted with the load's inertia and friction levels (module docstring).

    Parameters
    ----------
    prep : Prepared
    fit : FitResult
        The loop's final fit, with backlash named.
    stiffness : float
        Declared gear stiffness [N·m/rad or N/m].
    gap0 : float
        The loop's gap (massless description) [rad or m]: the centre of the search.
    k_folds : int
        Blocks of the cross-validation (the loop's).

    Returns
    -------
    (float or None, dict)
        The two-mass gap [rad or m], or None where it does not predict held-out blocks better than
        ``fit`` (or cannot be computed); the dict has the evidence: ``load_share``,
        ``damping_ratio``, ``gap``, ``coulomb_scale`` and ``viscous_scale`` (the refitted load
        friction over the fit's), ``load_coulomb_massless`` [N·m or N] and ``load_viscous_massless``
        [N·m·s/rad or N·s/m] (the fit's), ``rss``, ``rss_massless``, ``cv_gain_pct``, ``cv_z``,
        ``motor_inertia`` [kg·m² or kg] and, when refused, ``why``.

    Raises
    ------
    ValueError
        ``stiffness`` is not a positive finite number, or ``gap0`` is not positive.
    """
    check_stiffness(stiffness)
    if not (math.isfinite(gap0) and gap0 > 0):
        raise ValueError(f"two_mass_gap: the loop's gap must be positive, got {gap0!r}")
    try:
        tm = TwoMass(prep, fit, stiffness)
    except ValueError as exc:
        return None, {"why": str(exc)}
    lo = MIN_TRANSITION_COUNTS * prep.position_resolution
    g_lo, g_hi = max(lo, gap0 / GAP_SPAN), gap0 * GAP_SPAN
    if not g_hi > g_lo:
        return None, {"why": f"the gap's search window ends below {MIN_TRANSITION_COUNTS:g} position quanta"}
    share, zeta = NOMINAL_SHARE, NOMINAL_ZETA
    gap = _best_gap(tm, share, zeta, g_lo, g_hi, GAP_GRID_POINTS, math.log(GAP_SPAN ** 2) / (GAP_GRID_POINTS - 1))
    if gap is None:
        return None, {"why": f"the drive needs more than {MAX_SUBSTEPS} sub-steps per sample"}
    scales = (1.0, 1.0)
    f0 = tm.friction
    if JOINT_FRICTION:
        gap, scales = _joint_refit(tm, share, zeta, gap, g_lo, g_hi)
    y = tm.target(share, zeta, gap)
    coef, r = _solve(tm.X, y, tm.names)
    info: dict[str, Any] = {"load_share": share, "damping_ratio": zeta, "gap": gap, "rss": float(r @ r),
                            "coulomb_scale": scales[0], "viscous_scale": scales[1],
                            "load_coulomb_massless": 0.5 * (f0.coulomb_pos + f0.coulomb_neg),
                            "load_viscous_massless": 0.5 * (f0.viscous_pos + f0.viscous_neg),
                            "rss_massless": float(fit.rss), "motor_inertia": float(coef[0])}
    g, z = cv_compare(cv_losses(prep, fit.spec, k_folds), cv_losses_xy(tm.names, tm.X, y, k_folds))
    info.update(cv_gain_pct=g, cv_z=z)
    if not g > 0:
        info["why"] = (f"the two-mass description does not predict held-out blocks better than the loop's "
                       f"(gain {g:.2f} %, z = {z:.1f})")
        return None, info
    return gap, info


def gap_against_compliance(prep: Prepared, fit: FitResult, stiffness: float, width: float,
                           k_folds: int = 8) -> tuple[float, float, dict[str, Any]]:
    """Does a gap in the gear predict held-out blocks better than the same two-mass drive without one?

    Session 38: the loop's backlash candidate is massless (a play on the logged position, or a gap
    inside a massless declared spring) and must beat the current model with the declared spring in it
    (:func:`plant.calibration.loop._beats_gear_spring`). On the blind generator's drives the massless
    spring often beats the massless play while the drive has a gap; and a gap in a massless spring
    was not kept as the candidate because it imitated a compliant mode's ringing (sessions 24 and 31:
    "a compliant-mode description with the load's inertia for the gap to compete against" was
    missing). This compares the two with the load's inertia: :class:`TwoMass` built on ``fit`` (the
    current model, without backlash), load share :data:`NOMINAL_SHARE` and ζ :data:`NOMINAL_ZETA`, the
    fit's friction in both; the gap searched on a log grid from :data:`MIN_TRANSITION_COUNTS` quanta
    to :data:`GAP_SPAN` × ``width`` (:data:`GAP_GRID_POINTS` points per factor 16), then refined
    between the grid's neighbours; without a gap the gear is a linear spring and damper (a compliant
    mode). Blocked cross-validation as the loop's.

    Parameters
    ----------
    prep : Prepared
    fit : FitResult
        The current model (no backlash in it), with a positive inertia.
    stiffness : float
        Declared gear stiffness [N·m/rad or N/m].
    width : float
        The massless candidate's width [rad or m]: the top of the search is :data:`GAP_SPAN` times it.
    k_folds : int

    Returns
    -------
    (float, float, dict)
        Cross-validated gain [%] of the gap over the compliant mode and its ``z``; the evidence
        (``gap``, ``rss_gap``, ``rss_compliant``, ``load_share``, ``damping_ratio``) or ``why``
        (gain and z then 0).
    """
    check_stiffness(stiffness)
    try:
        tm = TwoMass(prep, fit, stiffness)
    except ValueError as exc:
        return 0.0, 0.0, {"why": str(exc)}
    share, zeta = NOMINAL_SHARE, NOMINAL_ZETA
    g_lo = MIN_TRANSITION_COUNTS * prep.position_resolution
    g_hi = GAP_SPAN * width
    if not (math.isfinite(g_hi) and g_hi > g_lo > 0):
        return 0.0, 0.0, {"why": f"no gap above {MIN_TRANSITION_COUNTS:g} position quanta to search"}
    y0 = tm.target(share, zeta, 0.0)
    if y0 is None:
        return 0.0, 0.0, {"why": f"the drive needs more than {MAX_SUBSTEPS} sub-steps per sample"}
    n = max(3, int(math.ceil(GAP_GRID_POINTS * math.log(g_hi / g_lo) / math.log(GAP_SPAN ** 2))))
    gap = _best_gap(tm, share, zeta, g_lo, g_hi, n, math.log(g_hi / g_lo) / (n - 1))
    if gap is None:
        return 0.0, 0.0, {"why": f"the drive needs more than {MAX_SUBSTEPS} sub-steps per sample"}
    y1 = tm.target(share, zeta, gap)
    _, r0 = _solve(tm.X, y0, tm.names)
    _, r1 = _solve(tm.X, y1, tm.names)
    g, z = cv_compare(cv_losses_xy(tm.names, tm.X, y0, k_folds), cv_losses_xy(tm.names, tm.X, y1, k_folds))
    return g, z, {"gap": gap, "rss_gap": float(r1 @ r1), "rss_compliant": float(r0 @ r0), "load_share": share,
                  "damping_ratio": zeta}
