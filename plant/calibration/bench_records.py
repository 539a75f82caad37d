"""An independent record generator for the calibration benchmark (imports nothing from ``plant``).

Written from the equations, not from :mod:`plant.effects`, :mod:`plant.axis` or
:mod:`plant.calibration.fit` (``tests/test_calibration_benchmark.py`` checks by AST that this
module imports only ``math``, ``dataclasses``, ``numpy`` and, optionally, ``numba``), so that the
calibration loop is tested on data whose physics, integrator and measurement chain it has not
seen.

Physics (axis side, SI)
-----------------------
* A rotary axis, rigid (one inertia) or a **two-mass drive** (motor inertia ``J_m`` and load
  inertia ``J_l`` coupled by a gear stiffness ``k`` and damping ``c``): with a **dead zone** of
  total width ``b`` for backlash (the coupling torque is ``k·(δ ∓ b/2)`` once the gap is closed,
  0 inside it) or, out of the library, without a gap but soft (a compliant mode at a few Hz).
* **LuGre friction** on the load with its bristle state ``z`` (Canudas de Wit et al. 1995):
  ``ż = ω − σ0|ω| z / g(ω)``, ``g(ω) = Fc + (Fs − Fc) exp(−(ω/vs)²)``,
  ``F = σ0 z + σ1 ż + Fv ω``; ``Fc`` and ``Fv`` may differ between the directions
  (``asymmetric_friction``). Bristles are always on: in records without ``presliding`` the
  pre-sliding displacement ``Fc/σ0`` is below one encoder count (not resolvable); with
  ``presliding`` it is tens to hundreds of counts.
* Additive load torques: ``A sin(2π θ/P + φ)`` (position-periodic), ``A sin(θ + φ)`` (gravity
  imbalance), ``A sin(2π f t + φ)`` (time-periodic), a constant offset.
* Out of the library: friction drift (``Fc``, ``Fv`` scaled by ``1 + a·exp(−t/τ)``, a warm-up;
  or by ``1 − β·T`` with a temperature ``T`` heated by the friction power), a **delay** between
  the commanded torque and the torque on the shaft, a **compliant mode** (two-mass, no gap).
* Integrator: semi-implicit Euler at a sub-step ``h`` chosen from the stiffest mode
  (``h·sqrt(σ0/J) ≤ 0.2``, ``h·σ1/J ≤ 0.5``, ``h·sqrt(k/J_m) ≤ 0.2``): the bristle state is
  advanced implicitly with the old velocity (``z ← (z + h ω)/(1 + h σ0 |ω|/g)``, stable at any
  stiffness), then the velocities with the new forces, then the angles with the new velocities.

Measurement chain
-----------------
* A discrete **PI velocity loop** at 1 kHz (or 2 kHz) on the velocity from **differenced motor
  encoder counts**, gains from the total inertia and a random bandwidth; its output is the
  commanded torque. A first-order current loop (0.2–1 ms) makes the torque on the shaft.
* Logged at 200 Hz–1 kHz (every k-th controller tick): ``torque_nm`` = the commanded torque plus
  white noise — or, for some records, the **current-derived torque** (shaft torque plus noise,
  quantised to an ADC step); ``position_rad`` = the **quantised absolute** motor-side encoder
  (2^20–2^26 counts/rev, referred to the axis); ``velocity_rad_s`` = differenced counts.

Randomised per record (seeded by the record's seed only): effect kind(s), amplitude (from near the
noise floor to dominant), period (2–50 cycles over the travel), phases, trajectory (velocity
staircase in both directions, back-and-forth sweeps over 30–180°, sinusoids, slow tracking with
fast slews back), noise, sample rate and length.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

try:  # optional: the interpreted kernel is the same code, ≈100× slower
    from numba import njit as _njit

    _jit = _njit(cache=False)
except ImportError:  # pragma: no cover - numba is a declared dependency
    def _jit(f):
        return f

__all__ = ["LIBRARY_KINDS", "OUT_OF_LIBRARY", "BenchRecord", "make_record", "plan", "DEFAULT_SEEDS", "CI_SEEDS"]

#: Kind names of the effects library, spelled here on purpose (not imported: this generator must
#: not depend on plant/). The benchmark checks they equal ``plant.effects.EFFECT_KINDS``.
LIBRARY_KINDS = ("asymmetric_friction", "position_periodic", "gravity_imbalance", "presliding", "backlash",
                 "time_periodic")
#: Out-of-library effects this generator can hide in a record.
OUT_OF_LIBRARY = ("friction_drift_time", "friction_drift_temperature", "delay", "compliant_mode")

_PAIRS = (
    ("asymmetric_friction", "position_periodic"), ("position_periodic", "time_periodic"),
    ("gravity_imbalance", "position_periodic"), ("backlash", "time_periodic"),
    ("presliding", "gravity_imbalance"), ("asymmetric_friction", "backlash"),
    ("time_periodic", "gravity_imbalance"), ("presliding", "position_periodic"),
)


def plan() -> list[tuple[str, ...]]:
    """The fixed benchmark plan: for seed ``s`` the hidden effects are ``plan()[s % len(plan())]``.

    60 entries: every library kind alone five times, 8 pairs, 10 clean records, each of the
    4 out-of-library effects 3 times.
    """
    out: list[tuple[str, ...]] = []
    for _ in range(5):
        out += [(k,) for k in LIBRARY_KINDS]
    out += list(_PAIRS)
    out += [()] * 10
    for _ in range(3):
        out += [(k,) for k in OUT_OF_LIBRARY]
    return out


#: The benchmark's seed list (one record per seed).
DEFAULT_SEEDS = tuple(range(60))
#: The fixed subset CI runs: clean ×2, every library kind, one pair, two out-of-library.
CI_SEEDS = (0, 1, 2, 3, 4, 5, 30, 38, 39, 48, 50)


@dataclasses.dataclass
class BenchRecord:
    """One generated record and its truth.

    Attributes
    ----------
    seed : int
    hidden : tuple of str
        Hidden effects (library kinds and/or out-of-library names); empty for a clean record.
    truth : dict
        Key parameters of the hidden library effects, ``{kind: {param: value}}`` (SI, axis side).
    t_s, torque_nm, position_rad, velocity_rad_s : ndarray, shape (N,)
    meta : dict
        Everything else that was drawn (trajectory, rates, noise, baseline friction …).
    """

    seed: int
    hidden: tuple[str, ...]
    truth: dict
    t_s: np.ndarray
    torque_nm: np.ndarray
    position_rad: np.ndarray
    velocity_rad_s: np.ndarray
    meta: dict

    def write_csv(self, path) -> None:
        """Write ``time_s, torque_nm, position_rad, velocity_rad_s`` with a header row."""
        arr = np.column_stack([self.t_s, self.torque_nm, self.position_rad, self.velocity_rad_s])
        np.savetxt(path, arr, delimiter=",", header="time_s,torque_nm,position_rad,velocity_rad_s", comments="",
                   fmt="%.12g")


# -- the integrator ---------------------------------------------------------------------------------------------------

@_jit
def _simulate(v_ref, ctrl_dt, n_sub, log_every, p):  # pragma: no cover - compiled
    """Closed-loop simulation; returns (commanded torque, shaft torque, motor angle) at every controller tick."""
    (J_m, J_l, two_mass, k_sp, c_sp, gap_h, sigma0, sigma1, fv_p, fv_n, fc_p, fc_n, fs_ratio, vs, offset,
     pp_a, pp_p, pp_ph, gr_a, gr_ph, tp_a, tp_f, tp_ph, drift_a, drift_tau, temp_beta, temp_tau, temp_gain,
     kp, ki, cpr, delay_ticks, tau_cur, v_filt) = p
    n = v_ref.size
    h = ctrl_dt / n_sub
    cmd_out = np.zeros(n)
    shaft_out = np.zeros(n)
    th_out = np.zeros(n)
    thm = 0.0
    wm = 0.0
    thl = 0.0
    wl = 0.0
    z = 0.0
    temp = 0.0
    integ = 0.0
    tq = 0.0
    cnt_prev = 0.0
    v_est = 0.0
    nd = int(delay_ticks)
    buf = np.zeros(nd + 1)
    a_cur = math.exp(-h / tau_cur)
    a_vf = math.exp(-ctrl_dt / v_filt)
    J = J_m + J_l
    t = 0.0
    for i in range(n):
        # controller: differenced encoder counts -> velocity estimate -> PI -> commanded torque
        cnt = math.floor(thm * cpr)
        v_raw = (cnt - cnt_prev) / (cpr * ctrl_dt) if i > 0 else 0.0
        cnt_prev = cnt
        v_est = a_vf * v_est + (1.0 - a_vf) * v_raw
        e = v_ref[i] - v_est
        integ += ki * e * ctrl_dt
        u = kp * e + integ
        cmd_out[i] = u
        # torque-to-motion delay (out of library): a FIFO of commanded torques
        for j in range(nd):
            buf[j] = buf[j + 1]
        buf[nd] = u
        u_app = buf[0]
        for s in range(n_sub):
            t = (i * n_sub + s) * h
            tq = u_app + (tq - u_app) * a_cur  # current loop
            # friction level (drift out of the library)
            scale = 1.0 + drift_a * math.exp(-t / drift_tau) - temp_beta * temp
            w = wl if two_mass else wm
            th = thl if two_mass else thm
            fc = fc_p if w > 0 else (fc_n if w < 0 else 0.5 * (fc_p + fc_n))
            fv = fv_p if w >= 0 else fv_n
            fc *= scale
            fv *= scale
            g = fc * (1.0 + (fs_ratio - 1.0) * math.exp(-(w / vs) ** 2))
            z_new = (z + h * w) / (1.0 + h * sigma0 * abs(w) / g)
            zdot = (z_new - z) / h
            z = z_new
            fr = sigma0 * z + sigma1 * zdot + fv * w
            load = offset + pp_a * math.sin(2.0 * math.pi * th / pp_p + pp_ph) + gr_a * math.sin(th + gr_ph) \
                + tp_a * math.sin(2.0 * math.pi * tp_f * t + tp_ph)
            temp += h * (temp_gain * abs(fr * w) - temp) / temp_tau
            if two_mass:
                d = thm - thl
                if d > gap_h:
                    tc = k_sp * (d - gap_h) + c_sp * (wm - wl)
                elif d < -gap_h:
                    tc = k_sp * (d + gap_h) + c_sp * (wm - wl)
                else:
                    tc = 0.0
                wm += h * (tq - tc) / J_m
                wl += h * (tc - fr - load) / J_l
                thm += h * wm
                thl += h * wl
            else:
                wm += h * (tq - fr - load) / J
                thm += h * wm
        shaft_out[i] = tq
        th_out[i] = thm
    return cmd_out, shaft_out, th_out


# -- trajectories -----------------------------------------------------------------------------------------------------

def _rate_limit(v: np.ndarray, a_max: float, dt: float) -> np.ndarray:
    out = np.empty_like(v)
    cur = 0.0
    dv = a_max * dt
    for i, x in enumerate(v.tolist()):
        cur += min(max(x - cur, -dv), dv)
        out[i] = cur
    return out


def _trajectory(rng: np.random.Generator, kind: str, travel: float, vmax: float, dt: float) -> np.ndarray:
    """Velocity set-point [rad/s] at the controller rate."""
    if kind == "staircase":
        # log-spaced levels, each +v then −v (net travel ≈ 0, a reversal at every level)
        n_lev = int(rng.integers(5, 9))
        levels = vmax * np.logspace(-2.0, 0.0, n_lev)
        segs = []
        for v in levels:
            hold = min(max(0.5 * travel / v, 1.0), 6.0)
            segs += [(v, hold), (-v, hold)]
        segs = [(0.0, 0.5)] + segs + [(0.0, 0.5)]
    elif kind == "sweep":
        n_pass = int(rng.integers(4, 9))
        levels = vmax * rng.uniform(0.2, 1.0, size=n_pass)
        segs = [(0.0, 0.5)]
        sign = 1.0
        for v in levels:
            v = max(v, travel / 20.0)  # passes of at most 20 s (records stay 30–200 s long)
            segs.append((sign * v, travel / v))
            sign = -sign
        segs.append((0.0, 0.5))
    elif kind == "sinusoid":
        period = float(rng.uniform(4.0, 20.0))
        period = min(max(period, math.pi * travel / vmax), 30.0)
        n_cyc = int(rng.integers(3, 8))
        t = np.arange(0.0, n_cyc * period, dt)
        v = 0.5 * travel * 2 * math.pi / period * np.sin(2 * math.pi * t / period)
        return _rate_limit(v, 4 * vmax, dt)
    else:  # tracking: slow constant rate across the travel, fast slew back
        run = float(rng.uniform(15.0, 40.0))
        v_track = min(travel / run, 0.2 * vmax)
        run = travel / v_track
        v_slew = max(vmax, travel / 10.0)
        # track both ways (else the two directions never share a speed and asymmetric friction is
        # not identifiable); slews of at most 10 s
        segs = [(0.0, 0.5), (v_track, run), (-v_slew, travel / v_slew), (-v_track, run), (v_slew, travel / v_slew)]
        segs.append((0.0, 0.5))
    v = np.concatenate([np.full(max(int(round(d / dt)), 1), lvl) for lvl, d in segs])
    return _rate_limit(v, vmax / float(rng.uniform(0.1, 0.5)), dt)


def _log_uniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


# -- one record -------------------------------------------------------------------------------------------------------

def make_record(seed: int, hidden: tuple[str, ...] | None = None, n_samples: int | None = None) -> BenchRecord:
    """Generate the benchmark record of ``seed``.

    Parameters
    ----------
    seed : int
        Seeds every random draw; ``hidden`` defaults to ``plan()[seed % 60]``.
    hidden : tuple of str, optional
        Override the hidden effects (library kinds and/or :data:`OUT_OF_LIBRARY` names).
    n_samples : int, optional
        Make a long record of this many logged samples (the trajectory is repeated): the hour-long
        log benchmark.

    Raises
    ------
    ValueError
        Unknown effect name.
    """
    rng = np.random.default_rng(10_000 + seed)
    if hidden is None:
        pl = plan()
        hidden = pl[seed % len(pl)]
    for h in hidden:
        if h not in LIBRARY_KINDS + OUT_OF_LIBRARY:
            raise ValueError(f"unknown hidden effect {h!r}; valid: {list(LIBRARY_KINDS + OUT_OF_LIBRARY)}")
    ctrl_dt = 1e-3 if rng.uniform() < 0.7 else 5e-4
    fs_log = float(rng.choice([200.0, 250.0, 500.0, 1000.0]))
    log_every = max(int(round(1.0 / (fs_log * ctrl_dt))), 1)
    J = _log_uniform(rng, 0.5, 20.0)
    fc = _log_uniform(rng, 1.0, 20.0)
    vmax = _log_uniform(rng, 0.05, 0.5)
    fv = fc * _log_uniform(rng, 0.3, 3.0) / vmax
    fs_ratio = float(rng.uniform(1.0, 1.4))
    vs = vmax * _log_uniform(rng, 0.005, 0.05)
    offset = fc * float(rng.uniform(-0.3, 0.3))
    noise = fc * _log_uniform(rng, 0.005, 0.03)
    cpr = 2.0 ** int(rng.integers(20, 27)) / (2 * math.pi)  # counts per rad (referred to the axis)
    res = 1.0 / cpr
    travel = math.radians(float(rng.uniform(30.0, 180.0)))
    traj = str(rng.choice(["staircase", "sweep", "sinusoid", "tracking"]))
    sigma0 = fc / (res * float(rng.uniform(0.05, 0.5)))  # pre-sliding displacement below one count
    sigma1 = 0.0
    meta: dict = {"J": J, "fc": fc, "fv": fv, "fs_ratio": fs_ratio, "vs": vs, "offset": offset, "noise": noise,
                  "counts_per_rad": cpr, "travel_rad": travel, "trajectory": traj, "vmax": vmax, "fs_log_hz": fs_log,
                  "ctrl_dt_s": ctrl_dt}
    truth: dict = {}
    fv_p = fv_n = fv
    fc_p = fc_n = fc
    pp = (0.0, 1.0, 0.0)
    gr = (0.0, 0.0)
    tp = (0.0, 1.0, 0.0)
    two_mass, J_m, J_l, k_sp, c_sp, gap_h = 0.0, J, 0.0, 0.0, 0.0, 0.0
    drift_a, drift_tau, temp_beta, temp_tau, temp_gain = 0.0, 1.0, 0.0, 1.0, 0.0
    delay_ticks = 0
    v_ref = _trajectory(rng, traj, travel, vmax, ctrl_dt)
    if n_samples is not None:
        reps = math.ceil(n_samples * log_every / v_ref.size)
        v_ref = np.tile(v_ref, reps)[: n_samples * log_every]
    T = v_ref.size * ctrl_dt
    amp = lambda lo, hi: fc * _log_uniform(rng, lo, hi)  # noqa: E731
    for h in hidden:
        if h == "asymmetric_friction":
            r = float(rng.uniform(1.25, 1.7))
            if rng.uniform() < 0.5:
                fv_p, fv_n = fv, fv * r
            else:
                fv_p, fv_n = fv * r, fv
            q = float(rng.uniform(0.8, 1.25))
            fc_p, fc_n = fc * q, fc / q
            truth[h] = {"viscous_pos_nm_s_rad": fv_p, "viscous_neg_nm_s_rad": fv_n}
        elif h == "position_periodic":
            cycles = _log_uniform(rng, 2.0, 50.0)
            pp = (amp(0.05, 1.0), travel / cycles, float(rng.uniform(-math.pi, math.pi)))
            truth[h] = {"period_rad": pp[1], "amplitude_nm": pp[0]}
        elif h == "gravity_imbalance":
            gr = (amp(0.1, 2.0), float(rng.uniform(-math.pi, math.pi)))
            truth[h] = {"amplitude_nm": gr[0]}
        elif h == "time_periodic":
            f = _log_uniform(rng, max(3.0 / T, 0.03), 8.0)
            tp = (amp(0.03, 1.0), f, float(rng.uniform(-math.pi, math.pi)))
            truth[h] = {"frequency_hz": f, "amplitude_nm": tp[0]}
        elif h == "presliding":
            disp = res * _log_uniform(rng, 30.0, 300.0)
            sigma0 = fc / disp
            sigma1 = float(rng.uniform(0.0, 1.0)) * math.sqrt(sigma0 * J)
            truth[h] = {"sigma0_nm_rad": sigma0}
        elif h in ("backlash", "compliant_mode"):
            two_mass = 1.0
            ratio = float(rng.uniform(0.5, 2.0))  # J_l / J_m
            J_m, J_l = J / (1 + ratio), J * ratio / (1 + ratio)
            j_eff = J_m * J_l / J
            if h == "backlash":
                width = max(_log_uniform(rng, 3e-5, 1e-3), 50 * res)
                f_res, zeta = float(rng.uniform(30.0, 80.0)), 0.2
                gap_h = 0.5 * width
                truth[h] = {"width_rad": width}
            else:
                f_res, zeta = float(rng.uniform(3.0, 12.0)), float(rng.uniform(0.02, 0.08))
                meta["resonance_hz"] = f_res
            k_sp = j_eff * (2 * math.pi * f_res) ** 2
            c_sp = 2 * zeta * math.sqrt(k_sp * j_eff)
            meta["two_mass"] = {"J_m": J_m, "J_l": J_l, "stiffness_nm_rad": k_sp, "damping_nms_rad": c_sp,
                                "resonance_hz": f_res}
        elif h == "friction_drift_time":
            drift_a, drift_tau = float(rng.uniform(0.2, 0.5)), T / float(rng.uniform(2.0, 5.0))
            meta["drift"] = {"a": drift_a, "tau_s": drift_tau}
        elif h == "friction_drift_temperature":
            p_mean = fc * vmax * 0.5
            temp_tau = T / float(rng.uniform(1.5, 4.0))
            temp_gain = 1.0 / p_mean  # temperature ≈ 1 at the mean friction power
            temp_beta = float(rng.uniform(0.2, 0.4))
            meta["drift"] = {"beta": temp_beta, "tau_s": temp_tau}
        elif h == "delay":
            delay_ticks = int(round(_log_uniform(rng, 5e-3, 2e-2) / ctrl_dt))
            meta["delay_s"] = delay_ticks * ctrl_dt
    fbw = float(rng.uniform(5.0, 20.0))
    if "compliant_mode" in hidden:
        fbw = min(fbw, 0.4 * meta["resonance_hz"])
    kp = J * 2 * math.pi * fbw
    ki = kp * 2 * math.pi * fbw / 4.0
    tau_cur = float(rng.uniform(2e-4, 1e-3))
    v_filt = 1.0 / (2 * math.pi * float(rng.uniform(100.0, 300.0)))
    # sub-step from the stiffest mode
    w_stiff = math.sqrt(sigma0 / (J_l if two_mass else J))
    if two_mass:
        w_stiff = max(w_stiff, math.sqrt(k_sp / min(J_m, J_l)))
    h_max = min(0.2 / w_stiff, 0.5 * (J_l if two_mass else J) / max(sigma1, 1e-12), ctrl_dt)
    n_sub = max(int(math.ceil(ctrl_dt / h_max)), 1)
    p = (J_m, J_l, two_mass, k_sp, c_sp, gap_h, sigma0, sigma1, fv_p, fv_n, fc_p, fc_n, fs_ratio, vs, offset,
         pp[0], pp[1], pp[2], gr[0], gr[1], tp[0], tp[1], tp[2], drift_a, drift_tau, temp_beta, temp_tau, temp_gain,
         kp, ki, cpr, float(delay_ticks), tau_cur, v_filt)
    p = tuple(float(x) for x in p)
    cmd, shaft, th = _simulate(np.ascontiguousarray(v_ref, dtype=np.float64), ctrl_dt, n_sub, log_every, p)
    # logging: every log_every-th controller tick
    idx = np.arange(0, cmd.size, log_every)
    dt_log = ctrl_dt * log_every
    current_derived = rng.uniform() < 0.3
    if current_derived:
        lsb = noise * float(rng.uniform(0.5, 2.0))
        torque = np.round((shaft[idx] + rng.normal(0.0, noise, idx.size)) / lsb) * lsb
    else:
        torque = cmd[idx] + rng.normal(0.0, noise, idx.size)
    counts = np.floor(th[idx] * cpr)
    pos = counts / cpr
    vel = np.concatenate([[0.0], np.diff(counts) / (cpr * dt_log)])
    meta.update({"n_substeps": n_sub, "kp": kp, "ki": ki, "bandwidth_hz": fbw, "current_derived_torque": bool(current_derived),
                 "resolution_rad": res})
    return BenchRecord(seed=seed, hidden=tuple(hidden), truth=truth, t_s=idx * ctrl_dt, torque_nm=torque,
                       position_rad=pos, velocity_rad_s=vel, meta=meta)
