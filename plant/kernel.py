"""Integrator kernels of :class:`plant.axis.AxisPlant`, compiled with numba when it is installed.

The second-order exponential-midpoint scheme of ``plant/axis.py`` (see its module docstring and
``shared/notes/FACTS.md``) written as plain functions of float tuples, so that one source serves
two ways of running it:

* **compiled** (default): numba ``njit`` turns these functions into machine code the first time
  they are called (cached on disk next to this file, ``cache=True``). One 5 ms tick of the
  twin-train plant then costs a few µs instead of ≈25 µs of interpreted Python — the plant was
  ≈30 % of the whole network's run time (``schmidt-fil bench``).
* **interpreted**: the very same functions run as Python when numba is not importable or when
  the environment variable ``SCHMIDT_FIL_JIT=0`` is set (debugging, coverage, a Python that
  numba does not support yet). ``tests/test_plant_kernel.py`` checks that both agree.

Why numba and not hand-written C: the kernel is the project's physics and must stay readable
and testable as Python; numba compiles that Python unchanged, is well kept, and needs no
compiler on the user's machine (wheels). ``fastmath`` is off: IEEE semantics, so results are
deterministic and agree with the interpreted path to rounding.

Tuples (all floats, SI)
-----------------------
state ``X`` (11): θ, ω, z, φa, ωa, ia, φb, ωb, ib, a_prev, load_prev — axis angle [rad], rate
[rad/s], LuGre bristle deflection [rad], motor shaft angles [rad], rates [rad/s], armature
currents [A], the bristle decay rate |ω|/g(ω) of the previous substep's midpoint [1/s] and the
additive load torque of the previous midpoint [N·m].

parameters ``P`` (22), built by :func:`pack_parameters`: see there.

gear lines ``G``: float64 array of shape (n, 4) from
:func:`plant.gear_train_disturbance.lines_table` (source, order, amplitude, phase), evaluated by
:func:`gear_lines_torque_nm` at each substep's midpoint and added to the load by
:func:`twin_run_lines` / :func:`rigid_run_lines`. :func:`twin_run` / :func:`rigid_run` pass an
empty table, so their numbers are those of the kernel before the lines existed.

Nothing here reads the clock, sleeps or keeps state between calls.
"""

from __future__ import annotations

import math
import os

import numpy as np

__all__ = ["JIT", "BACKEND", "interpreted", "pack_parameters", "mesh_torque_nm", "twin_midpoint", "twin_finish",
           "twin_run", "rigid_midpoint", "rigid_finish", "rigid_run", "N_STATE", "gear_lines_torque_nm",
           "twin_run_lines", "rigid_run_lines"]

N_STATE = 11

_jit_wanted = os.environ.get("SCHMIDT_FIL_JIT", "1").strip() not in ("0", "false", "no", "off")
try:
    if not _jit_wanted:
        raise ImportError("disabled by SCHMIDT_FIL_JIT=0")
    from numba import njit as _njit

    def _jit(fn):
        return _njit(cache=True, fastmath=False, error_model="numpy")(fn)

    JIT = True
except ImportError:  # numba missing or disabled: the same functions, interpreted
    def _jit(fn):
        return fn

    JIT = False

#: "numba" or "python": how the kernels run in this process.
BACKEND = "numba" if JIT else "python"


def interpreted():
    """A separate copy of this module with every function interpreted (``SCHMIDT_FIL_JIT=0``).

    For comparisons in tests and ``schmidt-fil bench``; the plant itself uses this module.

    Returns
    -------
    module
        With the same functions as :mod:`plant.kernel` and ``BACKEND == "python"``.
    """
    import importlib.util

    old = os.environ.get("SCHMIDT_FIL_JIT")
    os.environ["SCHMIDT_FIL_JIT"] = "0"
    try:
        spec = importlib.util.spec_from_file_location("plant.kernel_interpreted", __file__)
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
    finally:
        if old is None:
            del os.environ["SCHMIDT_FIL_JIT"]
        else:
            os.environ["SCHMIDT_FIL_JIT"] = old
    return mod


def pack_parameters(*, n, jm, cm, k, kt, ct, hb, j, r, l, vs, friction, perfect, rated) -> tuple:
    """Build the parameter tuple ``P`` the kernels take.

    Parameters
    ----------
    n : float
        Gear ratio motor : axis (360.489, paper §2.2).
    jm, cm : float
        Rotor inertia [kg·m²] and motor viscous drag [N·m·s/rad].
    k : float
        Motor torque / back-EMF constant [N·m/A = V·s/rad].
    kt, ct : float
        Mesh stiffness [N·m/rad] and damping [N·m·s/rad] of one train, at the axis.
    hb : float
        Half the backlash of one train at the axis [rad].
    j : float
        Axis inertia [kg·m²].
    r, l : float
        Armature resistance [Ω] and inductance [H].
    vs : float
        Supply voltage [V].
    friction : plant.friction.LuGre
        Resolved LuGre parameters (σ0, σ1, Tc±, Ts, ωs, δ, σ2±).
    perfect : bool
        Friction σ2·ω only (no bristles).
    rated : float
        Motor current rating [A]; substeps above it are counted.

    Returns
    -------
    tuple of 22 floats
        n⁻¹, Jm, cm, K, kt, ct, hb, J, R, R/L, Vs, σ0, σ1, σ2+, σ2−, Tc+, Tc−, Ts, ωs, δ,
        perfect (1.0/0.0), rated. (n itself is not needed: the kernels use n⁻¹ and rebuild n.)
    """
    f = friction
    return (1.0 / n, float(jm), float(cm), float(k), float(kt), float(ct), float(hb), float(j),
            float(r), float(r) / float(l), float(vs),
            float(f.sigma0_nm_rad), float(f.sigma1_nm_s_rad), float(f.sigma2_pos_nm_s_rad),
            float(f.sigma2_neg_nm_s_rad), float(f.tc_pos_nm), float(f.tc_neg_nm), float(f.ts_nm),
            float(f.omega_s_rad_s), float(f.delta), 1.0 if perfect else 0.0, float(rated))


# ---------------------------------------------------------------------------------- building blocks

@_jit
def gear_lines_torque_nm(th_rad, ang_a_rad, ang_b_rad, G):
    """Sum of the gear-train torque lines at one instant [N·m at the axis, load sign].

    Parameters
    ----------
    th_rad : float
        Axis angle [rad].
    ang_a_rad, ang_b_rad : float
        Motor angles of trains A and B reflected to the axis, φk / N [rad].
    G : ndarray, shape (n, 4), or a tuple of n 4-tuples (interpreted use)
        :func:`plant.gear_train_disturbance.lines_table`: source (0 axis, 1 train A, 2 train B),
        order [cycles per axis rev], amplitude [N·m], phase [rad]. n = 0 gives exactly 0.0.

    Returns
    -------
    float
        Σ A sin(order · angle + phase).
    """
    t = 0.0
    for i in range(len(G)):
        row = G[i]  # row-wise indexing: fast on a tuple of tuples when interpreted, a view when compiled
        src = row[0]
        ang = th_rad if src == 0.0 else (ang_a_rad if src == 1.0 else ang_b_rad)
        t += row[2] * math.sin(row[1] * ang + row[3])
    return t


@_jit
def mesh_torque_nm(d_rad, rel_rate_rad_s, kt, ct, hb):
    """Torque one gear train applies to the axis [N·m].

    Parameters
    ----------
    d_rad : float
        Motor angle reflected to the axis minus the axis angle [rad].
    rel_rate_rad_s : float
        The same difference of rates [rad/s].
    kt, ct : float
        Mesh stiffness [N·m/rad] and damping [N·m·s/rad] of the train.
    hb : float
        Half the backlash at the axis [rad].

    Returns
    -------
    float
        0 inside the dead zone; outside it, spring plus damper, clipped so that the teeth only
        push (never pull).
    """
    if d_rad > hb:
        t = kt * (d_rad - hb) + ct * rel_rate_rad_s
        return t if t > 0.0 else 0.0
    if d_rad < -hb:
        t = kt * (d_rad + hb) + ct * rel_rate_rad_s
        return t if t < 0.0 else 0.0
    return 0.0


@_jit
def _armature(i0, iss, er, fr, rl, h):
    """One armature current over a step with the back-EMF frozen: exact exponential, diode clamp.

    ``i → iss + (i0 − iss)e^{−(R/L)h}``; the low-side switch conducts one way only, so the current
    stops at 0 (exact zero-crossing time). Returns (i at step end, mean i over the step) [A].
    """
    i1 = iss + (i0 - iss) * er
    if i1 >= 0.0:
        return i1, iss + (i0 - iss) * fr
    if i0 > 0.0:
        tz = math.log((i0 - iss) / (-iss)) / rl
        return 0.0, (iss * tz + i0 / rl) / h
    return 0.0, 0.0


@_jit
def _bristle(z, w, a, h):
    """LuGre z over ``h`` with the decay rate ``a`` = |ω|/g(ω) frozen: exact exponential.

    Returns (z at step end, mean z over the step) [rad]. ``a`` = 0 (ω = 0): z integrates ω.
    """
    x = a * h
    if x > 0.0:
        zs = w / a
        om = -math.expm1(-x)
        return zs + (z - zs) * (1.0 - om), zs + (z - zs) * om / x
    return z + h * w, z + 0.5 * h * w


@_jit
def _decay_rate(w, P):
    """a = |ω|·σ0/g(ω), g the Stribeck curve (paper eq. 4) for the sign of ω [1/s]."""
    aw = -w if w < 0.0 else w
    if aw == 0.0:
        return 0.0
    tc = P[15] if w >= 0.0 else P[16]
    u = aw / P[18]
    delta = P[19]
    sg = tc + (P[17] - tc) * math.exp(-(u * u if delta == 2.0 else u ** delta))
    return aw * P[11] / sg


@_jit
def _predictor_friction(z, w, a_prev, hh, P):
    """Friction torque over the predictor half step ``hh`` [N·m]: σ0 z̄ + σ1 Δz/hh + σ2 ω, with z
    advanced exactly at the previous midpoint's decay rate (σ2 ω alone for a perfect plant)."""
    s2 = P[13] if w >= 0.0 else P[14]
    if P[20] != 0.0:
        return s2 * w
    zh, zbar = _bristle(z, w, a_prev, hh)
    return P[11] * zbar + P[12] * (zh - z) / hh + s2 * w


@_jit
def _step_bristles(z, w_h, h, P):
    """Bristle state over the full step with ω frozen at the midpoint ``w_h``.

    Returns (z at step end [rad], σ0 z̄ + σ1 Δz/h [N·m], decay rate a [1/s]); all zero for a
    perfect plant.
    """
    if P[20] != 0.0:
        return 0.0, 0.0, 0.0
    a = _decay_rate(w_h, P)
    z1, zbar = _bristle(z, w_h, a, h)
    return z1, P[11] * zbar + P[12] * (z1 - z) / h, a


# ---------------------------------------------------------------------------------- twin train

@_jit
def twin_midpoint(X, P, h):
    """Stage 1 (predictor to t + h/2) of the twin-train substep.

    Returns (θ½, ω½, φa½, ωa½, φb½, ωb½).
    """
    th, w, z, pa, wa, ia, pb, wb, ib, a_prev, load_prev = X
    n_inv, jm, cm, k, kt, ct, hb, j = P[0], P[1], P[2], P[3], P[4], P[5], P[6], P[7]
    hh = 0.5 * h
    ta = mesh_torque_nm(pa * n_inv - th, wa * n_inv - w, kt, ct, hb)
    tb = mesh_torque_nm(pb * n_inv - th, wb * n_inv - w, kt, ct, hb)
    f = _predictor_friction(z, w, a_prev, hh, P)
    return (th + hh * w,
            w + hh * (ta + tb - f - load_prev) / j,
            pa + hh * wa,
            wa + hh * (k * ia - ta * n_inv - cm * wa) / jm,
            pb + hh * wb,
            wb + hh * (-k * ib - tb * n_inv - cm * wb) / jm)


@_jit
def twin_finish(X, M, P, duty_a, duty_b, h, er, fr, load):
    """Stage 2 of the twin-train substep: the full step with every coefficient frozen at ``M``.

    Parameters
    ----------
    X : tuple
        State at the step start.
    M : tuple
        :func:`twin_midpoint` of ``X``.
    P : tuple
        :func:`pack_parameters`.
    duty_a, duty_b : float
        PWM duties 0..1 held over the step.
    h : float
        Step [s].
    er, fr : float
        e^{−(R/L)h} and (1 − er)/((R/L)h).
    load : float
        Additive load torque at the midpoint [N·m].

    Returns
    -------
    (X1, ta, tb, friction_nm)
        New state; the two mesh torques at the midpoint [N·m]; the friction torque over the step
        [N·m].
    """
    th, w, z, pa, wa, ia, pb, wb, ib, a_prev, load_prev = X
    th_h, w_h, pa_h, wa_h, pb_h, wb_h = M
    n_inv, jm, cm, k, kt, ct, hb, j = P[0], P[1], P[2], P[3], P[4], P[5], P[6], P[7]
    r, rl, vs = P[8], P[9], P[10]
    hh = 0.5 * h
    ta = mesh_torque_nm(pa_h * n_inv - th_h, wa_h * n_inv - w_h, kt, ct, hb)
    tb = mesh_torque_nm(pb_h * n_inv - th_h, wb_h * n_inv - w_h, kt, ct, hb)
    ia1, ia_m = _armature(ia, (duty_a * vs - k * wa_h) / r, er, fr, rl, h)
    ib1, ib_m = _armature(ib, (duty_b * vs + k * wb_h) / r, er, fr, rl, h)
    wa1 = wa + h * (k * ia_m - ta * n_inv - cm * wa_h) / jm
    wb1 = wb + h * (-k * ib_m - tb * n_inv - cm * wb_h) / jm
    s2 = P[13] if w_h >= 0.0 else P[14]
    z1, fz, a = _step_bristles(z, w_h, h, P)
    w1 = (j * w + h * (ta + tb - fz - load) - hh * s2 * w) / (j + hh * s2)
    X1 = (th + hh * (w + w1), w1, z1, pa + hh * (wa + wa1), wa1, ia1,
          pb + hh * (wb + wb1), wb1, ib1, a, load)
    return X1, ta, tb, fz + 0.5 * s2 * (w + w1)


@_jit
def _run(rigid, X, P, G, duty_a, duty_b, span_us, max_substep_us):
    """Substep loop shared by :func:`twin_run` and :func:`rigid_run` (and their ``_lines`` forms).

    The drive model is a flag rather than a function argument so that numba can cache the
    compiled loop on disk (functions passed as arguments make it uncacheable). ``G`` is the
    gear-line table (shape (n, 4)); with n = 0 the load is exactly 0.0, as before the lines existed.
    """
    rl = P[9]
    n_inv = P[0]
    n_lines = len(G)
    load = 0.0
    rated = P[21]
    ta = tb = ff = 0.0
    peak_a = X[5]
    peak_b = X[8]
    over_a = 0
    over_b = 0
    h_last = -1
    er = fr = h = 0.0
    left = span_us
    while left > 0:
        h_us = max_substep_us if left > max_substep_us else left
        if h_us != h_last:
            h = h_us * 1e-6
            er = math.exp(-rl * h)
            fr = (1.0 - er) / (rl * h)
            h_last = h_us
        if rigid:
            Mr = rigid_midpoint(X, P, h)
            if n_lines > 0:
                load = gear_lines_torque_nm(Mr[0], Mr[0], Mr[0], G)
            X, ta, tb, ff = rigid_finish(X, Mr, P, duty_a, duty_b, h, er, fr, load)
        else:
            Mt = twin_midpoint(X, P, h)
            if n_lines > 0:
                load = gear_lines_torque_nm(Mt[0], Mt[2] * n_inv, Mt[4] * n_inv, G)
            X, ta, tb, ff = twin_finish(X, Mt, P, duty_a, duty_b, h, er, fr, load)
        ia1 = X[5]
        ib1 = X[8]
        if ia1 > peak_a:
            peak_a = ia1
        if ib1 > peak_b:
            peak_b = ib1
        if ia1 > rated:
            over_a += h_us
        if ib1 > rated:
            over_b += h_us
        left -= h_us
    return X, ta, tb, ff, peak_a, peak_b, over_a, over_b


@_jit
def twin_run(X, P, duty_a, duty_b, span_us, max_substep_us):
    """Advance the twin-train plant ``span_us`` in substeps of at most ``max_substep_us``.

    No additive load (the caller runs :func:`twin_midpoint`/:func:`twin_finish` itself when it
    has load effects). Returns (X1, ta, tb, friction_nm, peak_ia, peak_ib, over_a_us, over_b_us):
    the last substep's mesh and friction torques, the largest currents of the span (including
    the start) [A] and the µs spent above the rating per motor.
    """
    return _run(False, X, P, np.empty((0, 4)), duty_a, duty_b, span_us, max_substep_us)


@_jit
def twin_run_lines(X, P, G, duty_a, duty_b, span_us, max_substep_us):
    """:func:`twin_run` with the gear-train torque lines ``G`` (see :func:`gear_lines_torque_nm`)
    added to the load at every substep's midpoint."""
    return _run(False, X, P, G, duty_a, duty_b, span_us, max_substep_us)


# ---------------------------------------------------------------------------------- rigid drive

@_jit
def rigid_midpoint(X, P, h):
    """Stage 1 of the rigid-drive substep (φk = Nθ, inertia J + 2JmN²). Returns (θ½, ω½)."""
    th, w, z, pa, wa, ia, pb, wb, ib, a_prev, load_prev = X
    n = 1.0 / P[0]
    kn = P[3] * n
    jr = P[7] + 2.0 * P[1] * n * n
    cmr = 2.0 * P[2] * n * n
    hh = 0.5 * h
    f = _predictor_friction(z, w, a_prev, hh, P)
    return th + hh * w, w + hh * (kn * (ia - ib) - f - cmr * w - load_prev) / jr


@_jit
def rigid_finish(X, M, P, duty_a, duty_b, h, er, fr, load):
    """Stage 2 of the rigid-drive substep; same contract as :func:`twin_finish`."""
    th, w, z, pa, wa, ia, pb, wb, ib, a_prev, load_prev = X
    th_h, w_h = M
    n = 1.0 / P[0]
    k = P[3]
    kn = k * n
    jr = P[7] + 2.0 * P[1] * n * n
    cmr = 2.0 * P[2] * n * n
    r, rl, vs = P[8], P[9], P[10]
    hh = 0.5 * h
    wm = n * w_h
    ia1, ia_m = _armature(ia, (duty_a * vs - k * wm) / r, er, fr, rl, h)
    ib1, ib_m = _armature(ib, (duty_b * vs + k * wm) / r, er, fr, rl, h)
    s2 = (P[13] if w_h >= 0.0 else P[14]) + cmr
    z1, fz, a = _step_bristles(z, w_h, h, P)
    ta = kn * ia_m
    tb = -kn * ib_m
    w1 = (jr * w + h * (ta + tb - fz - load) - hh * s2 * w) / (jr + hh * s2)
    th1 = th + hh * (w + w1)
    X1 = (th1, w1, z1, th1 * n, w1 * n, ia1, th1 * n, w1 * n, ib1, a, load)
    return X1, ta, tb, fz + 0.5 * (s2 - cmr) * (w + w1)


@_jit
def rigid_run(X, P, duty_a, duty_b, span_us, max_substep_us):
    """:func:`twin_run` for the rigid drive."""
    return _run(True, X, P, np.empty((0, 4)), duty_a, duty_b, span_us, max_substep_us)


@_jit
def rigid_run_lines(X, P, G, duty_a, duty_b, span_us, max_substep_us):
    """:func:`twin_run_lines` for the rigid drive (every line follows the axis angle)."""
    return _run(True, X, P, G, duty_a, duty_b, span_us, max_substep_us)
