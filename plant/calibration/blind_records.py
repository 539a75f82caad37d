"""Blind synthetic drive records for checking a friction/drive calibration tool.

This module was written *blind*: from the physical equations stated in its
brief (LuGre friction, rigid and two-mass drive trains, a sampled cascade
controller, a current loop and a measurement chain) without reading the
calibration code, the project's other record generator, its data or its
tests.  It imports only the standard library, numpy, scipy and (optionally)
numba, so it can be used to test whether the calibration tool generalises
to records it was never developed on.

Each record is one rotary, telescope-like axis moved by a motor in closed
loop.  A record hides zero, one or two "effects" from
:data:`LIBRARY_KINDS`, or one effect from :data:`OUT_OF_LIBRARY`; which
ones is given by :func:`plan`.  Every random draw comes from
``numpy.random.default_rng(seed + _SEED_OFFSET)``, so a record is fully
deterministic per seed.

Units are SI throughout: s, rad, rad/s, N·m, N·m·s/rad, N·m/rad, kg·m².

Modelling choices (all of them)
-------------------------------
Geometry and units
    * Everything is reflected to the axis: motor angle / gear ratio, motor
      inertia × ratio², torque × ratio.  ``torque_nm`` is the drive torque
      at the axis, ``position_rad`` is the axis angle (rigid records) or the
      motor angle / ratio (two-mass records).
    * The encoder is an absolute *multi-turn* encoder with 2**k counts/rev,
      k drawn uniformly in 20…26 and then raised (at most to 26) if needed
      so that one count moves the velocity-loop torque command by <= Fc
      (an engineer would not pair a coarse encoder with a stiff loop);
      the position never wraps.  Quantisation is ``floor(theta / q) * q``
      with ``q = 2*pi / 2**k``; the controller sees the same counts.
    * Start angle theta0 uniform in [0, 2*pi) (matters for gravity).
Rigid axis
    * ``J dv/dt = tau_drive - F_LuGre(v, z) - tau_load(theta, v, t)``;
      J log-uniform in 0.5…20 kg·m².
    * Fc is drawn log-uniform in [0.5, min(20, 10 J, 2e-3 rad · k_pos /
      (Fs/Fc))] N·m, k_pos = Kv·Kp being the loop's low-frequency
      stiffness: friction never decelerates the axis faster than 10 rad/s²
      and the breakaway torque never needs more than ~2 mrad of position
      error (a telescope axis is inertia-dominated; without this bound the
      delay-limited loops hunt by degrees, which no real drive is left
      doing).  Consequence: Fc is skewed towards the low end of 0.5…20.
    * ``tau_load = offset + effects``; offset = ±U(0, 0.1)·Fc (cable drag).
Friction (LuGre, Canudas de Wit et al. 1995)
    * ``dz/dt = v - sigma0 |v| / g(v) z``,
      ``g(v) = Fc + (Fs - Fc) exp(-|v / vs|**delta)``,
      ``F = sigma0 z + sigma1 dz/dt + Fv v``.
    * Fc as above, Fs/Fc uniform 1.05…1.6, vs log-uniform 1e-4…5e-3 rad/s,
      delta uniform 1…2.
    * Fv log-uniform in [max(1, 0.05 Fc / v_max), 200] N·m·s/rad where
      v_max is the largest commanded speed: the viscous torque is never
      below 5 % of Fc at the fastest speed of the record (otherwise a
      viscous asymmetry could be unobservable by construction).
    * Stiff bristles (no ``presliding``): ``Fs/sigma0`` = 0.05…0.6 encoder
      counts, sigma1 = 2 zeta sqrt(sigma0 J_load), zeta 0.05…0.3.
    * ``presliding``: ``Fc/sigma0`` = 20…300 counts (log-uniform),
      sigma1 = 2 zeta sqrt(sigma0 J_load), zeta 0.3…1.
Integrator (inner loop, numba ``@njit`` with a no-op fallback)
    * Each control period Tc is split into ``n_sub = max(2, ceil(Tc /
      1e-4 s))`` substeps h <= 100 µs.
    * Current loop: first-order lag, integrated *exactly* per substep
      (``tau += (u - tau)(1 - exp(-h/tau_i))``).
    * Load (friction side): linearly-implicit backward Euler on (v, z).  The
      coefficient ``a = sigma0 |v| / g(v)`` is frozen at the old velocity,
      z is eliminated (``z1 = (z0 + h v1)/(1 + h a)``) and the resulting
      scalar equation for v1 is solved exactly, including the
      direction-dependent viscous term (piecewise linear, monotone: try the
      v>0 branch, then the v<0 branch, else v1 = 0).  Then z is updated
      again by backward Euler with ``a`` evaluated at the *new* velocity,
      which makes z1 a convex combination of z0 and the steady deflection
      ``sign(v1) g(v1)/sigma0``: |z| <= Fs/sigma0 for *any* h.  Backward
      Euler is A-stable: with stiff bristles the sliding relaxation rate
      ``a = sigma0 |v| / g`` reaches 1e5…1e9 1/s (h·a up to ~1e5) and the
      bristle/inertia mode sqrt(sigma0/J) up to ~1e5 rad/s; both are
      damped instead of blowing up, whereas explicit Euler would need
      h < 2/a, i.e. sub-microsecond steps.
    * Position-, time-dependent torques and the gear spring are explicit
      (their rates, <= 2 pi·40 Hz, give omega h <= 0.03; symplectic Euler
      for the motor inertia).
Two-mass drive (``backlash``, ``compliant_mode``)
    * Motor share of J uniform 20…70 %; gear spring K from the two-mass
      resonance ``f_r = sqrt(K (1/Jm + 1/Jl)) / 2 pi`` (backlash 5…40 Hz,
      compliant_mode 3…15 Hz, log-uniform); gear damping c = 2 zeta_g
      sqrt(K Jm Jl / J), zeta_g 0.02…0.1.
    * Dead zone of total width b (20…400 counts): the gear transmits
      ``K (d - b/2) + c dd`` for d > b/2, ``K (d + b/2) + c dd`` for
      d < -b/2 (d = theta_m - theta_l), but never pulls while separating
      (unilateral contact, clamped at 0); inside ±b/2 nothing.
    * Friction and all load torques act on the load; controller and encoder
      on the motor.  Initial state: gear pre-loaded by the static load.
Controller (sampled, f_ctrl in {500, 800, 1000, 1200, 1500, 1600, 2000} Hz)
    * Cascade: P position loop (Kp = omega_v / U(3, 6)) + PI velocity loop
      (Kv = J omega_v, PI zero at omega_v / U(3, 6)) with velocity
      feed-forward from the trajectory, on the *quantised* encoder position.
      Speed estimate: differenced counts, first-order low-pass at
      4 omega_v.  Anti-windup: integration stops while the command is
      clamped at ±tau_max (generous).
    * omega_v = U(0.2, 0.4) / T_d with T_d = Tc (1 + calc_delay) + tau_i
      (phase margin ~35…55 deg with the speed filter and the PI zero);
      two-mass records scale omega_v by Jm/J (the collocated loop crosses
      over on Jm).  If even 26 encoder bits leave one count moving the
      command by more than Fc, omega_v is lowered (floor 2 rad/s).
    * calc_delay 0 or 1 control period (command applied at once or at the
      next tick).  The integrator starts at the static load torque (the
      drive was holding the axis before the log starts).
Current loop: first-order lag, tau_i uniform 0.2…2 ms.
Measurement chain (logged torque)
    * "command": the torque command at the sample instant plus noise.
    * "current": measured current × Kt = current-loop output + sensor noise,
      anti-alias RC low-pass (cut-off fs_log/3 × U(0.9, 1.1), discretised
      at f_ctrl), then a 10…12-bit ADC over ±U(1.5, 3) × peak |torque|.
    * Noise std 0.2…3 % of Fc (log-uniform) as seen in the logged torque;
      white in 70 % of records, first-order low-pass ("coloured", corner
      0.2…20 Hz) in the rest.  In "current" records it is added before the
      ADC, so it also dithers the ADC.
    * Log rate fs_log = f_ctrl / m (m integer, 200…1000 Hz; m >= 2 in
      ~85 % of records); decimation by plain sampling.  Duration 30…200 s,
      clipped so that N is 10k…150k samples.  Position and torque are
      sampled at the same control tick (the torque before the tick's
      update, i.e. the current-loop output present at that instant).
    * Noise generator: a second ``default_rng`` seeded from the record rng.
Trajectories (per record; all start at rest)
    * "staircase": 3…6 speeds, log-uniform 5e-5…0.05 rad/s, each run
      + then - (order ascending, descending or random); plateaus listed in
      ``meta["trajectory_info"]["plateaus"]`` as [t0, t1, v].
    * "sweep": constant-rate legs back and forth over 30…180 deg.
    * "sinusoid": theta = A (1 - cos(2 pi t / Tp)), A 5…60 deg, Tp 5…60 s
      (peak speed <= 0.5 rad/s).
    * "tracking": sidereal-like 7.29e-5 rad/s (±10 %) interrupted by 2…3
      slews at 0.03…0.2 rad/s over 10…90 deg.
    * Velocity ramps between segments at a limited acceleration.
    * ``meta["n_reversals"]`` counts sign changes of the commanded velocity;
      ``meta["travel_rad"]`` is the commanded range max - min.
Hidden library effects (positive torque opposes positive drive)
    * ``asymmetric_friction``: Fv+ / Fv- ratio 1.2…2 either way; Coulomb
      and static levels also differ by ±0…5 % with direction.
    * ``position_periodic``: A sin(2 pi theta/P + phi) of the load angle; P
      = travel / n, n log-uniform 2…50; A 3…100 % of Fc.
    * ``gravity_imbalance``: A sin(theta_load + phi), A 5…200 % of Fc; only on
      trajectories with travel >= 60 deg.
    * ``presliding``: compliant bristles (above).
    * ``backlash``: two-mass drive with dead zone (above).
    * ``time_periodic``: A sin(2 pi f t + phi), f log-uniform in
      [max(0.02, 3/T), min(10, fs_log/4)] Hz, A 3…100 % of Fc.
Out-of-library effects (no truth entry)
    * ``friction_drift``: warm-up; Fc, Fs scale by (1 + s dc·w(t)) and Fv by
      (1 + s dv·w(t)), dc, dv 10…40 %, w(t) an exponential going from 1 to 0
      over the record with time constant 0.1…0.5 T; s = -1 (friction
      falls, warm-up) in 75 % of records, +1 otherwise.
    * ``torque_delay``: the logged torque leads the torque acting on the
      axis by d = 3…20 ms: ``logged(t) = tau(t + d)`` (linear interpolation
      between control ticks; the loop runs 25 ms past the log for this).
      Modelled as a time-stamp skew of the torque channel *outside* the
      control loop (torque stamped when issued, applied after a fixed
      fieldbus/drive latency), so the loop's own dynamics are unchanged;
      an in-loop delay of 20 ms made the delay-limited loops hunt.
    * ``compliant_mode``: two-mass drive without dead zone, 3…15 Hz.
    * ``load_dependent_friction``: the bearing's normal load changes with
      the axis attitude; Coulomb and static friction scale by
      (1 + kappa |cos(theta + phi)|), kappa 0.3…1, with *no* net gravity
      torque (balanced axis).  Friction stays direction-odd, so this is
      not a position-periodic torque.  Travel >= 60 deg.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import signal

try:  # numba is a declared dependency but optional at run time
    from numba import njit
except ImportError:  # pragma: no cover - exercised only without numba

    def njit(*args, **kwargs):
        """No-op stand-in for :func:`numba.njit` (same call forms)."""
        if len(args) == 1 and callable(args[0]) and not kwargs:
            return args[0]

        def _decorate(func):
            return func

        return _decorate


__all__ = [
    "LIBRARY_KINDS",
    "OUT_OF_LIBRARY",
    "BLIND_SEEDS",
    "BlindRecord",
    "plan",
    "make_record",
]

LIBRARY_KINDS = (
    "asymmetric_friction",
    "position_periodic",
    "gravity_imbalance",
    "presliding",
    "backlash",
    "time_periodic",
)
OUT_OF_LIBRARY = (
    "friction_drift",
    "torque_delay",
    "compliant_mode",
    "load_dependent_friction",
)
BLIND_SEEDS: tuple[int, ...] = tuple(range(60))

_SEED_OFFSET = 0x0B11D5EED  # added to the seed before default_rng
_H_MAX = 1.0e-4  # s, largest integration substep
_HUNT_RAD = 2.0e-3  # rad, bound on Fs / loop stiffness (stick-slip scale)
_TWO_PI = 2.0 * math.pi
_DEG = math.pi / 180.0

_PAIRS = (
    ("asymmetric_friction", "position_periodic"),
    ("gravity_imbalance", "time_periodic"),
    ("presliding", "position_periodic"),
    ("backlash", "asymmetric_friction"),
    ("gravity_imbalance", "presliding"),
    ("time_periodic", "backlash"),
    ("asymmetric_friction", "time_periodic"),
    ("position_periodic", "gravity_imbalance"),
)


def _base_plan() -> list[tuple[str, ...]]:
    """The 60 hidden sets in canonical order (before interleaving)."""
    base: list[tuple[str, ...]] = []
    for kind in LIBRARY_KINDS:
        base += [(kind,)] * 5
    base += list(_PAIRS)
    base += [()] * 10
    n_ool = 60 - len(base)
    for i in range(n_ool):
        base.append((OUT_OF_LIBRARY[i % len(OUT_OF_LIBRARY)],))
    return base


def plan(n: int = 60) -> list[tuple[str, ...]]:
    """Hidden effect sets, one per seed.

    Parameters
    ----------
    n : int
        Number of entries.  The 60-entry plan is cycled (n > 60) or
        truncated (n < 60).

    Returns
    -------
    list of tuple of str
        ``plan()[i % len(plan())]`` is the hidden set of seed ``i``: 30
        single library kinds (5 each), 8 pairs (never backlash with
        presliding), 10 clean records and 12 out-of-library records (3 of
        each).  Kinds are interleaved by the fixed permutation
        ``i -> (37 i) mod 60``.
    """
    base = _base_plan()
    order = [base[(37 * i) % 60] for i in range(60)]
    return [order[i % 60] for i in range(n)]


@dataclass
class BlindRecord:
    """One synthetic measured record.

    Attributes
    ----------
    seed : int
        Seed of the record.
    hidden : tuple of str
        Hidden effects (library and/or out-of-library names).
    truth : dict
        ``{kind: {param: value}}`` for hidden library kinds only, SI units.
    t_s : numpy.ndarray
        Sample times, s, uniform from 0.
    torque_nm : numpy.ndarray
        Logged drive torque at the axis, N·m.
    position_rad : numpy.ndarray
        Logged, encoder-quantised position, rad (load side for rigid
        records, motor angle / ratio for two-mass records).
    meta : dict
        Every drawn quantity; always ``fs_log_hz``, ``trajectory`` and
        ``n_reversals``; ``two_mass`` for two-mass records.
    """

    seed: int
    hidden: tuple[str, ...]
    truth: dict
    t_s: np.ndarray
    torque_nm: np.ndarray
    position_rad: np.ndarray
    meta: dict = field(default_factory=dict)

    def write_csv(self, path) -> None:
        """Write ``time_s,torque_nm,position_rad`` rows with ``%.12g``.

        Parameters
        ----------
        path : str or path-like
            Output file.
        """
        data = np.column_stack([self.t_s, self.torque_nm, self.position_rad])
        np.savetxt(
            path,
            data,
            fmt="%.12g",
            delimiter=",",
            header="time_s,torque_nm,position_rad",
            comments="",
        )


# --------------------------------------------------------------------------
# inner integration loop
# --------------------------------------------------------------------------
@njit(cache=False)
def _g_stribeck(v, fc_p, fc_n, fs_p, fs_n, vs, delta, scale):
    """Stribeck curve g(v) in N·m (direction-dependent levels)."""
    if v >= 0.0:
        fc = fc_p
        fs = fs_p
    else:
        fc = fc_n
        fs = fs_n
    return scale * (fc + (fs - fc) * math.exp(-(abs(v) / vs) ** delta))


@njit(cache=False)
def _gear_torque(d, dd, k_gear, c_gear, half_b):
    """Gear torque (N·m) for twist d (rad) and twist rate dd (rad/s)."""
    if half_b <= 0.0:
        return k_gear * d + c_gear * dd
    if d > half_b:
        ts = k_gear * (d - half_b) + c_gear * dd
        return ts if ts > 0.0 else 0.0
    if d < -half_b:
        ts = k_gear * (d + half_b) + c_gear * dd
        return ts if ts < 0.0 else 0.0
    return 0.0


@njit(cache=False)
def _kernel(
    th_ref, v_ref, fc_fac, fv_fac,
    tc, n_sub, tau_i, calc_delay,
    kp, kv, ki, alpha_v, tau_max, q,
    jm, jl, two_mass, k_gear, c_gear, half_b,
    fc_p, fc_n, fs_p, fs_n, vs, delta, fv_p, fv_n, sigma0, sigma1,
    offset, a_pp, p_pp, ph_pp, a_g, ph_g, a_t, f_t, ph_t, kappa_ld, ph_ld,
    th_load0, tau0, twist0,
    out_cmd, out_act, out_meas, out_load, out_z, out_spring, out_twist,
):
    """Simulate the closed loop; all outputs sampled at the control ticks."""
    h = tc / n_sub
    e_i = math.exp(-h / tau_i)
    n_k = th_ref.shape[0]
    jload = jl
    thl = th_load0
    vl = 0.0
    z = 0.0
    thm = th_load0 + twist0
    vm = 0.0
    tau_a = tau0
    integ = tau0
    cmd_prev = tau0
    cmd_app = tau0
    th_meas0 = thm if two_mass else thl
    cnt_prev = math.floor(th_meas0 / q)
    v_f = 0.0
    for k in range(n_k):
        # ---- sample instant t_k: measure, control, log
        th_meas = thm if two_mass else thl
        cnt = math.floor(th_meas / q)
        pos_m = cnt * q
        v_raw = (cnt - cnt_prev) * q / tc
        cnt_prev = cnt
        v_f += alpha_v * (v_raw - v_f)
        e_p = th_ref[k] - pos_m
        e_v = v_ref[k] + kp * e_p - v_f
        u = kv * e_v + integ + ki * tc * e_v
        if u > tau_max:
            u = tau_max
        elif u < -tau_max:
            u = -tau_max
        else:
            integ += ki * tc * e_v
        out_cmd[k] = u
        out_act[k] = tau_a
        out_meas[k] = th_meas
        out_load[k] = thl
        out_z[k] = z
        if two_mass:
            out_twist[k] = thm - thl
            out_spring[k] = _gear_torque(thm - thl, vm - vl, k_gear, c_gear, half_b)
        if calc_delay:
            cmd_app = cmd_prev
            cmd_prev = u
        else:
            cmd_app = u
        ffc = fc_fac[k]
        ffv = fv_fac[k]
        fvp = fv_p * ffv
        fvn = fv_n * ffv
        # ---- substeps
        for j in range(n_sub):
            t = (k * n_sub + j) * h
            tau_a = cmd_app + (tau_a - cmd_app) * e_i
            tau_drv = tau_a
            tl = offset
            if a_pp != 0.0:
                tl += a_pp * math.sin(2.0 * math.pi * thl / p_pp + ph_pp)
            if a_g != 0.0:
                tl += a_g * math.sin(thl + ph_g)
            if a_t != 0.0:
                tl += a_t * math.sin(2.0 * math.pi * f_t * t + ph_t)
            scale = ffc
            if kappa_ld != 0.0:
                scale *= 1.0 + kappa_ld * abs(math.cos(thl + ph_ld))
            if two_mass:
                ts = _gear_torque(thm - thl, vm - vl, k_gear, c_gear, half_b)
                vm += h * (tau_drv - ts) / jm
                thm += h * vm
                tau_in = ts - tl
            else:
                tau_in = tau_drv - tl
            # linearly implicit step of (v, z), a frozen at old v
            v0 = vl
            g0 = _g_stribeck(v0, fc_p, fc_n, fs_p, fs_n, vs, delta, scale)
            a0 = sigma0 * abs(v0) / g0
            dd = 1.0 + h * a0
            cc = jload / h + (sigma0 * h + sigma1) / dd
            rr = jload * v0 / h + tau_in - (sigma0 - sigma1 * a0) * z / dd
            if rr > 0.0:
                v1 = rr / (cc + fvp)
            elif rr < 0.0:
                v1 = rr / (cc + fvn)
            else:
                v1 = 0.0
            g1 = _g_stribeck(v1, fc_p, fc_n, fs_p, fs_n, vs, delta, scale)
            a1 = sigma0 * abs(v1) / g1
            z = (z + h * v1) / (1.0 + h * a1)
            vl = v1
            thl += h * v1
            if not two_mass:
                thm = thl
                vm = vl
    return 0


# --------------------------------------------------------------------------
# random draws
# --------------------------------------------------------------------------
def _logu(rng, lo: float, hi: float) -> float:
    """Log-uniform draw in [lo, hi]."""
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _profile(segments, a_max: float, t: np.ndarray) -> np.ndarray:
    """Velocity (rad/s) on grid ``t`` for ``[(v_target, hold_s), ...]``.

    Ramps between targets at ``a_max`` (rad/s²); the last value is held.
    """
    times = [0.0]
    vels = [0.0]
    tt = 0.0
    v = 0.0
    for vt, hold in segments:
        tt += abs(vt - v) / a_max
        times.append(tt)
        vels.append(vt)
        tt += max(hold, 0.0)
        times.append(tt)
        vels.append(vt)
        v = vt
    return np.interp(t, np.asarray(times), np.asarray(vels))


def _integrate(v: np.ndarray, tc: float) -> np.ndarray:
    """Trapezoidal position (rad) from velocity (rad/s), starting at 0."""
    th = np.empty_like(v)
    th[0] = 0.0
    th[1:] = np.cumsum(0.5 * (v[1:] + v[:-1])) * tc
    return th


def _trajectory(rng, kind: str, t: np.ndarray, tc: float, dur: float,
                min_travel: float):
    """Draw a trajectory; returns (theta_rel, v, info)."""
    info: dict = {"kind": kind}
    if kind == "staircase":
        n_lv = int(rng.integers(3, 7))
        n_lv = max(3, min(n_lv, int((dur - 6.0) // 8.0)))
        speeds = [_logu(rng, 5e-5, 0.05) for _ in range(n_lv)]
        order = str(rng.choice(["up", "down", "random"]))
        if order == "up":
            speeds.sort()
        elif order == "down":
            speeds.sort(reverse=True)
        sgn = 1.0 if rng.random() < 0.5 else -1.0
        a_max = _logu(rng, 0.05, 0.5)
        rest0 = float(rng.uniform(0.5, 2.0))
        levels = []
        for s in speeds:
            levels += [sgn * s, -sgn * s]
        ramps = abs(levels[0]) / a_max + abs(levels[-1]) / a_max
        ramps += sum(abs(b - a) for a, b in zip(levels[:-1], levels[1:])) / a_max
        hold = (dur - rest0 - 2.0 - ramps) / len(levels)
        segs = [(0.0, rest0)] + [(lv, hold) for lv in levels] + [(0.0, dur)]
        v = _profile(segs, a_max, t)
        plateaus = []
        tt = rest0
        vprev = 0.0
        for lv in levels:
            tt += abs(lv - vprev) / a_max
            plateaus.append([tt, tt + hold, lv])
            tt += hold
            vprev = lv
        info.update(speeds_rad_s=speeds, order=order, a_max_rad_s2=a_max,
                    plateaus=plateaus, plateau_s=hold)
    elif kind == "sweep":
        rng_rad = float(rng.uniform(max(30.0, min_travel / _DEG), 180.0)) * _DEG
        legs = int(rng.integers(2, 9))
        rest0 = float(rng.uniform(0.5, 2.0))
        avail = 0.85 * (dur - rest0)
        legs = max(2, min(legs, int(0.2 * avail / rng_rad)))
        rate = legs * rng_rad / avail
        a_max = max(_logu(rng, 0.05, 0.5), 20.0 * legs * rate / dur)
        sgn = 1.0 if rng.random() < 0.5 else -1.0
        segs = [(0.0, rest0)]
        for i in range(legs):
            segs.append(((sgn if i % 2 == 0 else -sgn) * rate, rng_rad / rate))
        segs.append((0.0, dur))
        v = _profile(segs, a_max, t)
        info.update(range_rad=rng_rad, legs=legs, rate_rad_s=rate,
                    a_max_rad_s2=a_max)
    elif kind == "sinusoid":
        amp = float(rng.uniform(max(5.0, 0.5 * min_travel / _DEG), 60.0)) * _DEG
        lo = max(5.0, _TWO_PI * amp / 0.5)
        hi = max(lo, min(60.0, dur / 2.0))
        per = float(rng.uniform(lo, hi))
        sgn = 1.0 if rng.random() < 0.5 else -1.0
        w = _TWO_PI / per
        v = sgn * amp * w * np.sin(w * t)
        info.update(amplitude_rad=amp, period_s=per)
    elif kind == "tracking":
        rate = 7.29e-5 * float(rng.uniform(0.9, 1.1))
        rate *= 1.0 if rng.random() < 0.5 else -1.0
        n_sl = int(rng.integers(2, 4))
        a_max = _logu(rng, 0.05, 0.3)
        slews = []
        for _ in range(n_sl):
            spd = _logu(rng, 0.03, 0.2)
            ang = float(rng.uniform(10.0, 90.0)) * _DEG
            sg = 1.0 if rng.random() < 0.5 else -1.0
            slews.append((sg * spd, ang / spd))
        busy = sum(d for _, d in slews) + sum(2 * abs(s) / a_max for s, _ in slews)
        track = max(2.0, (dur - busy) / (n_sl + 1))
        segs = [(rate, track)]
        for s, d in slews:
            segs += [(s, d), (rate, track)]
        v = _profile(segs, a_max, t)
        info.update(track_rate_rad_s=rate, slews=[[s, d] for s, d in slews],
                    a_max_rad_s2=a_max, track_s=track)
    else:  # pragma: no cover
        raise ValueError(kind)
    th = _integrate(v, tc)
    return th, v, info


def _draw(seed: int, hidden: tuple[str, ...]) -> dict:
    """Draw every parameter of a record (no simulation).

    Parameters
    ----------
    seed : int
        Record seed.
    hidden : tuple of str
        Hidden effect names.

    Returns
    -------
    dict
        Drawn quantities (SI); private keys ``_sim`` (kernel arguments),
        ``_truth`` and ``_noise_seed`` are removed by :func:`make_record`.
    """
    rng = np.random.default_rng(seed + _SEED_OFFSET)
    hs = set(hidden)
    p: dict = {"seed": int(seed), "hidden": tuple(hidden)}

    # ---- sampling and duration
    f_ctrl = float(rng.choice([500, 800, 1000, 1200, 1500, 1600, 2000]))
    ms = [m for m in range(1, 11) if 200.0 <= f_ctrl / m <= 1000.0]
    fast = [m for m in ms if m >= 2]
    if fast and rng.random() < 0.85:
        m = int(rng.choice(fast))
    else:
        m = int(rng.choice(ms))
    fs = f_ctrl / m
    dur = float(rng.uniform(max(30.0, 1.0e4 / fs), min(200.0, 1.5e5 / fs)))
    n_log = int(round(dur * fs))
    dur = n_log / fs
    tc = 1.0 / f_ctrl
    n_k = n_log * m
    n_extra = int(math.ceil(0.025 / tc)) + 2  # simulated beyond the log (skew)
    bits = int(rng.integers(20, 27))
    p.update(f_ctrl_hz=f_ctrl, decimation=m, fs_log_hz=fs, duration_s=dur,
             n_samples=n_log, encoder_bits_drawn=bits)

    # ---- inertia, drive train
    jt = _logu(rng, 0.5, 20.0)
    two_mass = bool(hs & {"backlash", "compliant_mode"})
    jm, jl = jt, jt
    if two_mass:
        share = float(rng.uniform(0.2, 0.7))
        jm = share * jt
        jl = jt - jm
        if "backlash" in hs:
            f_r = _logu(rng, 5.0, 40.0)
            b_counts = _logu(rng, 20.0, 400.0)
        else:
            f_r = _logu(rng, 3.0, 15.0)
            b_counts = 0.0
        zeta_g = float(rng.uniform(0.02, 0.1))

    # ---- current loop and controller design (independent of friction)
    n_sub = max(2, int(math.ceil(tc / _H_MAX - 1e-9)))
    h = tc / n_sub
    tau_i = float(rng.uniform(0.2e-3, 2e-3))
    calc_delay = int(rng.integers(0, 2))
    t_d = tc * (1 + calc_delay) + tau_i
    c_bw = float(rng.uniform(0.2, 0.4))
    kp_ratio = float(rng.uniform(3.0, 6.0))
    ki_ratio = float(rng.uniform(3.0, 6.0))
    w_v = c_bw / t_d
    if two_mass:
        w_v *= jm / jt
    k_pos = jt * w_v * w_v / kp_ratio  # N·m/rad, low-frequency loop stiffness

    # ---- friction (Fc bounded by inertia and by loop stiffness)
    fs_ratio = float(rng.uniform(1.05, 1.6))
    fc_hi = min(20.0, 10.0 * jt, _HUNT_RAD * k_pos / fs_ratio)
    fc = _logu(rng, 0.5, max(0.5, fc_hi))
    vs = _logu(rng, 1e-4, 5e-3)
    delta = float(rng.uniform(1.0, 2.0))
    off = fc * float(rng.uniform(0.0, 0.1)) * (1.0 if rng.random() < 0.5 else -1.0)
    th0 = float(rng.uniform(0.0, _TWO_PI))
    p.update(inertia_kg_m2=jt, coulomb_nm=fc, static_over_coulomb=fs_ratio,
             stribeck_velocity_rad_s=vs, stribeck_exponent=delta,
             offset_nm=off, theta0_rad=th0)

    # ---- encoder: fine enough that one count moves the command by <= Fc
    alpha_v = 1.0 - math.exp(-4.0 * w_v * tc)
    q_need = fc * tc / (jt * w_v * alpha_v)
    bits = max(bits, min(26, int(math.ceil(math.log2(_TWO_PI / q_need)))))
    q = _TWO_PI / 2.0**bits
    for _ in range(40):  # still too coarse at 26 bits: lower the gain
        alpha_v = 1.0 - math.exp(-4.0 * w_v * tc)
        step = jt * w_v * q / tc * alpha_v
        if step <= fc * 1.0001 or w_v <= 2.0:
            break
        w_v = max(2.0, w_v * max(0.5, fc / step))
    alpha_v = 1.0 - math.exp(-4.0 * w_v * tc)
    kv = jt * w_v
    ki = kv * w_v / ki_ratio
    kp = w_v / kp_ratio
    p.update(encoder_bits=bits, counts_per_rev=2**bits, count_rad=q)

    # ---- trajectory
    min_travel = 60.0 * _DEG if hs & {"gravity_imbalance", "load_dependent_friction"} else 0.0
    t_c = np.arange(n_k + n_extra) * tc
    for _ in range(100):
        kind = str(rng.choice(["staircase", "sweep", "sinusoid", "tracking"]))
        th_rel, v_ref, tinfo = _trajectory(rng, kind, t_c, tc, dur, min_travel)
        travel = float(th_rel[:n_k].max() - th_rel[:n_k].min())
        if travel >= min_travel:
            break
    vv = v_ref[:n_k]
    nz = vv[np.abs(vv) > 1e-12]
    sg = np.sign(nz)
    n_rev = int(np.count_nonzero(sg[1:] != sg[:-1]))
    v_max = float(np.max(np.abs(vv)))
    a_max = float(np.max(np.abs(np.diff(v_ref)))) / tc
    p.update(trajectory=kind, trajectory_info=tinfo, travel_rad=travel,
             n_reversals=n_rev, v_max_rad_s=v_max, a_max_rad_s2=a_max)

    # ---- viscous friction and its asymmetry
    fv_lo = min(100.0, max(1.0, 0.05 * fc / max(v_max, 1e-9)))
    fv = _logu(rng, fv_lo, 200.0)
    fv_p = fv_n = fv
    fc_p = fc_n = fc
    if "asymmetric_friction" in hs:
        ratio = float(rng.uniform(1.2, 2.0))
        if rng.random() < 0.5:
            fv_p = fv * ratio
        else:
            fv_n = fv * ratio
        eps = float(rng.uniform(-0.05, 0.05))
        fc_p = fc * (1.0 + eps)
        fc_n = fc * (1.0 - eps)
        p["viscous_ratio"] = ratio
        p["coulomb_asymmetry"] = eps
    fs_p = fs_ratio * fc_p
    fs_n = fs_ratio * fc_n
    p.update(viscous_nm_s_rad=fv, viscous_pos_nm_s_rad=fv_p,
             viscous_neg_nm_s_rad=fv_n, coulomb_pos_nm=fc_p, coulomb_neg_nm=fc_n,
             static_pos_nm=fs_p, static_neg_nm=fs_n)

    # ---- gear
    k_gear = c_gear = half_b = 0.0
    if two_mass:
        jred = jm * jl / jt
        k_gear = (_TWO_PI * f_r) ** 2 * jred
        c_gear = 2.0 * zeta_g * math.sqrt(k_gear * jred)
        b = b_counts * q
        half_b = 0.5 * b
        p["two_mass"] = {
            "stiffness_nm_rad": k_gear,
            "motor_inertia_kg_m2": jm,
            "load_inertia_kg_m2": jl,
            "motor_share": share,
            "resonance_hz": f_r,
            "antiresonance_hz": math.sqrt(k_gear / jl) / _TWO_PI,
            "damping_nm_s_rad": c_gear,
            "damping_ratio": zeta_g,
            "backlash_width_rad": b,
            "backlash_width_counts": b_counts,
        }

    # ---- bristles
    fs_max = max(fs_p, fs_n)
    if "presliding" in hs:
        n_cnt = _logu(rng, 20.0, 300.0)
        sigma0 = fc / (n_cnt * q)
        zeta = float(rng.uniform(0.3, 1.0))
        p["presliding_counts"] = n_cnt
    else:
        n_cnt = float(rng.uniform(0.05, 0.6))
        sigma0 = fs_max / (n_cnt * q)
        zeta = float(rng.uniform(0.05, 0.3))
        p["bristle_counts_at_fs"] = n_cnt
    sigma1 = 2.0 * zeta * math.sqrt(sigma0 * jl)
    p.update(sigma0_nm_rad=sigma0, sigma1_nm_s_rad=sigma1, bristle_zeta=zeta)

    # ---- library torque effects
    truth: dict = {}
    a_pp = ph_pp = a_g = ph_g = a_t = f_t = ph_t = 0.0
    p_pp = 1.0
    if "position_periodic" in hs:
        n_per = _logu(rng, 2.0, 50.0)
        p_pp = travel / n_per
        a_pp = fc * _logu(rng, 0.03, 1.0)
        ph_pp = float(rng.uniform(0.0, _TWO_PI))
        truth["position_periodic"] = {"period_rad": p_pp, "amplitude_nm": a_pp}
        p["position_periodic"] = {"period_rad": p_pp, "amplitude_nm": a_pp,
                                  "phase_rad": ph_pp, "periods_in_travel": n_per}
    if "gravity_imbalance" in hs:
        a_g = fc * _logu(rng, 0.05, 2.0)
        ph_g = float(rng.uniform(0.0, _TWO_PI))
        truth["gravity_imbalance"] = {"amplitude_nm": a_g}
        p["gravity_imbalance"] = {"amplitude_nm": a_g, "phase_rad": ph_g}
    if "time_periodic" in hs:
        f_t = _logu(rng, max(0.02, 3.0 / dur), min(10.0, 0.24 * fs))
        a_t = fc * _logu(rng, 0.03, 1.0)
        ph_t = float(rng.uniform(0.0, _TWO_PI))
        truth["time_periodic"] = {"frequency_hz": f_t, "amplitude_nm": a_t}
        p["time_periodic"] = {"frequency_hz": f_t, "amplitude_nm": a_t,
                              "phase_rad": ph_t}
    if "asymmetric_friction" in hs:
        truth["asymmetric_friction"] = {"viscous_pos_nm_s_rad": fv_p,
                                        "viscous_neg_nm_s_rad": fv_n}
    if "presliding" in hs:
        truth["presliding"] = {"sigma0_nm_rad": sigma0}
    if "backlash" in hs:
        truth["backlash"] = {"width_rad": 2.0 * half_b}

    # ---- out-of-library effects
    fc_fac = np.ones(n_k + n_extra)
    fv_fac = np.ones(n_k + n_extra)
    if "friction_drift" in hs:
        dc = float(rng.uniform(0.1, 0.4))
        dv = float(rng.uniform(0.1, 0.4))
        tau_d = dur * float(rng.uniform(0.1, 0.5))
        s = -1.0 if rng.random() < 0.75 else 1.0
        w = (np.exp(-t_c / tau_d) - math.exp(-dur / tau_d)) / (1.0 - math.exp(-dur / tau_d))
        # w goes 1 -> 0 over the record: friction starts at (1 - s d), ends nominal
        fc_fac = 1.0 - s * dc * w
        fv_fac = 1.0 - s * dv * w
        p["friction_drift"] = {"coulomb_change": dc, "viscous_change": dv,
                               "time_constant_s": tau_d, "direction": s}
    kappa_ld = ph_ld = 0.0
    if "load_dependent_friction" in hs:
        kappa_ld = float(rng.uniform(0.3, 1.0))
        ph_ld = float(rng.uniform(0.0, _TWO_PI))
        p["load_dependent_friction"] = {"kappa": kappa_ld, "phase_rad": ph_ld}
    skew = 0.0
    if "torque_delay" in hs:
        skew = float(rng.uniform(3e-3, 20e-3))
        p["torque_delay"] = {"delay_s": skew}

    tau_max = 4.0 * (fs_max * (1.0 + kappa_ld) * 1.4 + max(fv_p, fv_n) * 1.4 * v_max
                     + jt * a_max + abs(off) + a_pp + a_g + a_t) + fc
    p["controller"] = {
        "structure": "P position + PI velocity, velocity feed-forward",
        "omega_v_rad_s": w_v, "kv_nm_s_rad": kv, "ki_nm_rad": ki,
        "kp_1_s": kp, "speed_filter_rad_s": 4.0 * w_v,
        "calc_delay_ticks": calc_delay, "tau_max_nm": tau_max,
        "current_lag_s": tau_i, "n_substeps": n_sub, "substep_s": h,
        "loop_stiffness_nm_rad": kv * kp,
    }

    # ---- measurement chain
    chain = "current" if rng.random() < 0.5 else "command"
    noise_std = fc * _logu(rng, 0.002, 0.03)
    coloured = bool(rng.random() < 0.3)
    noise_corner = _logu(rng, 0.2, 20.0) if coloured else None
    mchain = {"logged": chain, "noise_std_nm": noise_std,
              "noise": "coloured" if coloured else "white",
              "noise_corner_hz": noise_corner, "torque_skew_s": skew}
    if chain == "current":
        mchain["adc_bits"] = int(rng.integers(10, 13))
        mchain["adc_range_over_peak"] = float(rng.uniform(1.5, 3.0))
        mchain["rc_cutoff_hz"] = fs / 3.0 * float(rng.uniform(0.9, 1.1))
    p["measurement"] = mchain
    noise_seed = int(rng.integers(0, 2**62))

    # ---- static load at the start (the drive holds the axis)
    tau0 = off + a_pp * math.sin(_TWO_PI * th0 / p_pp + ph_pp) + a_g * math.sin(th0 + ph_g) \
        + a_t * math.sin(ph_t)
    twist0 = 0.0
    if two_mass:
        twist0 = tau0 / k_gear + (math.copysign(half_b, tau0) if tau0 != 0.0 else 0.0)

    p["_sim"] = dict(
        th_ref=th0 + twist0 + th_rel, v_ref=v_ref, fc_fac=fc_fac, fv_fac=fv_fac,
        tc=tc, n_sub=n_sub, tau_i=tau_i, calc_delay=calc_delay,
        kp=kp, kv=kv, ki=ki, alpha_v=alpha_v, tau_max=tau_max, q=q,
        jm=jm, jl=jl, two_mass=two_mass, k_gear=k_gear, c_gear=c_gear,
        half_b=half_b, fc_p=fc_p, fc_n=fc_n, fs_p=fs_p, fs_n=fs_n, vs=vs,
        delta=delta, fv_p=fv_p, fv_n=fv_n, sigma0=sigma0, sigma1=sigma1,
        offset=off, a_pp=a_pp, p_pp=p_pp, ph_pp=ph_pp, a_g=a_g, ph_g=ph_g,
        a_t=a_t, f_t=f_t, ph_t=ph_t, kappa_ld=kappa_ld, ph_ld=ph_ld,
        th_load0=th0, tau0=tau0, twist0=twist0,
    )
    p["_truth"] = truth
    p["_noise_seed"] = noise_seed
    return p


def _simulate(p: dict) -> dict:
    """Run the closed loop for drawn parameters ``p`` (see :func:`_draw`).

    Returns
    -------
    dict
        Control-rate arrays: ``cmd`` (torque command, N·m), ``act``
        (current-loop output, N·m), ``meas`` (unquantised encoder-side
        angle, rad), ``load`` (load angle, rad), ``z`` (bristle deflection,
        rad), ``spring`` (gear torque, N·m) and ``twist`` (motor - load
        angle, rad); the last two are zero for rigid records.
    """
    s = p["_sim"]
    n_k = s["th_ref"].shape[0]
    out = {k: np.zeros(n_k) for k in ("cmd", "act", "meas", "load", "z", "spring", "twist")}
    _kernel(
        s["th_ref"], s["v_ref"], s["fc_fac"], s["fv_fac"],
        float(s["tc"]), int(s["n_sub"]), float(s["tau_i"]), int(s["calc_delay"]),
        float(s["kp"]), float(s["kv"]), float(s["ki"]), float(s["alpha_v"]),
        float(s["tau_max"]), float(s["q"]),
        float(s["jm"]), float(s["jl"]), bool(s["two_mass"]), float(s["k_gear"]),
        float(s["c_gear"]), float(s["half_b"]),
        float(s["fc_p"]), float(s["fc_n"]), float(s["fs_p"]), float(s["fs_n"]),
        float(s["vs"]), float(s["delta"]), float(s["fv_p"]), float(s["fv_n"]),
        float(s["sigma0"]), float(s["sigma1"]),
        float(s["offset"]), float(s["a_pp"]), float(s["p_pp"]), float(s["ph_pp"]),
        float(s["a_g"]), float(s["ph_g"]), float(s["a_t"]), float(s["f_t"]),
        float(s["ph_t"]), float(s["kappa_ld"]), float(s["ph_ld"]),
        float(s["th_load0"]), float(s["tau0"]), float(s["twist0"]),
        out["cmd"], out["act"], out["meas"], out["load"], out["z"],
        out["spring"], out["twist"],
    )
    return out


def _coloured(rng, n: int, corner_hz: float, rate_hz: float) -> np.ndarray:
    """Unit-variance first-order low-pass (AR(1)) noise."""
    rho = math.exp(-_TWO_PI * corner_hz / rate_hz)
    w = rng.standard_normal(n) * math.sqrt(1.0 - rho * rho)
    x0 = rng.standard_normal()
    y, _ = signal.lfilter([1.0], [1.0, -rho], w, zi=[rho * x0])
    return y


def _at(x: np.ndarray, idx: np.ndarray, shift: float) -> np.ndarray:
    """``x`` at fractional indices ``idx + shift`` (linear interpolation)."""
    if shift == 0.0:
        return x[idx]
    i0 = int(math.floor(shift))
    fr = shift - i0
    return (1.0 - fr) * x[idx + i0] + fr * x[idx + i0 + 1]


def _log(p: dict, sim: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Measurement chain: time (s), logged torque (N·m), position (rad)."""
    m = p["decimation"]
    n = p["n_samples"]
    q = p["count_rad"]
    fs = p["fs_log_hz"]
    f_ctrl = p["f_ctrl_hz"]
    mc = p["measurement"]
    rng = np.random.default_rng(p["_noise_seed"])
    idx = np.arange(n) * m
    t = np.arange(n) / fs
    pos = np.floor(sim["meas"][idx] / q) * q
    shift = mc["torque_skew_s"] * f_ctrl  # control ticks the torque leads by
    std = mc["noise_std_nm"]
    if mc["logged"] == "command":
        if mc["noise"] == "white":
            nz = rng.standard_normal(n)
        else:
            nz = _coloured(rng, n, mc["noise_corner_hz"], fs)
        tq = _at(sim["cmd"], idx, shift) + std * nz
    else:
        x = sim["act"]
        n_k = x.shape[0]
        if mc["noise"] == "white":
            raw = rng.standard_normal(n_k)
        else:
            raw = _coloured(rng, n_k, mc["noise_corner_hz"], f_ctrl)
        alpha = 1.0 - math.exp(-_TWO_PI * mc["rc_cutoff_hz"] / f_ctrl)
        b, a = [alpha], [1.0, alpha - 1.0]
        xf, _ = signal.lfilter(b, a, x, zi=[(1.0 - alpha) * x[0]])
        nf, _ = signal.lfilter(b, a, raw, zi=[0.0])
        nf = nf[idx]
        nf *= std / max(float(np.std(nf)), 1e-300)
        y = _at(xf, idx, shift) + nf
        full = mc["adc_range_over_peak"] * float(np.max(np.abs(x)))
        lsb = 2.0 * full / 2 ** mc["adc_bits"]
        tq = np.clip(np.round(y / lsb) * lsb, -full, full - lsb)
        mc["adc_full_scale_nm"] = full
        mc["adc_lsb_nm"] = lsb
    return t, tq, pos


def _jsonable(x):
    """Convert numpy scalars / tuples in ``x`` to plain Python types."""
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.generic):
        return x.item()
    return x


def make_record(seed: int, hidden: tuple[str, ...] | None = None) -> BlindRecord:
    """Generate the record of ``seed``.

    Parameters
    ----------
    seed : int
        Record seed; draws come from ``default_rng(seed + _SEED_OFFSET)``.
    hidden : tuple of str, optional
        Hidden effects; default ``plan()[seed % 60]``.  Names must come from
        :data:`LIBRARY_KINDS` or :data:`OUT_OF_LIBRARY`.

    Returns
    -------
    BlindRecord
        Logged columns (``t_s`` in s, ``torque_nm`` in N·m,
        ``position_rad`` in rad), truth and meta.
    """
    if hidden is None:
        pl = plan()
        hidden = pl[seed % len(pl)]
    hidden = tuple(hidden)
    unknown = set(hidden) - set(LIBRARY_KINDS) - set(OUT_OF_LIBRARY)
    if unknown:
        raise ValueError(f"unknown effect kinds: {sorted(unknown)}")
    if "backlash" in hidden and "compliant_mode" in hidden:
        raise ValueError("backlash and compliant_mode are exclusive")
    p = _draw(seed, hidden)
    sim = _simulate(p)
    t, tq, pos = _log(p, sim)
    truth = p.pop("_truth")
    s = p.pop("_sim")
    p.pop("_noise_seed")
    p["peak_torque_nm"] = float(np.max(np.abs(sim["act"])))
    p["max_tracking_error_rad"] = float(np.max(np.abs(sim["meas"] - s["th_ref"])))
    meta = _jsonable(p)
    return BlindRecord(seed=int(seed), hidden=hidden, truth=truth, t_s=t,
                       torque_nm=tq, position_rad=pos, meta=meta)
