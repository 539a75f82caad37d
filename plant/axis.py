"""One telescope axis: two torque motors, two compliant gear trains with backlash, LuGre friction.

Model (``drive_model = "twin_train"``; paper §2.2, §3.2, §3.3, §4; parameters in
``plant/parameters.yaml``). States, all float, SI:

* axis angle θ [rad], rate ω [rad/s], LuGre bristle deflection z [rad] (axis side);
* per motor k ∈ {a, b}: shaft angle φk [rad], rate ωk [rad/s], armature current ik [A] (>= 0).

Equations (N = gear ratio, sk = +1 for motor A, −1 for motor B)::

    L dik/dt = dutyk·V − R ik − K sk ωk             ik clamped >= 0 (one-way low-side drive)
    Jm dωk/dt = sk K ik − Tk/N − cm ωk
    Tk = mesh(φk/N − θ, ωk/N − ω)                   spring kt with a dead zone of width b, plus
                                                     damping ct while engaged; contact cannot pull
    J dω/dt = Ta + Tb − F − Σ additive effects(θ, ω, t)
    F = σ0 z + σ1 dz/dt + σ2 ω,  dz/dt = ω − |ω| z / g(ω)       (paper eqs. 3–5)

kt = half the Table 1 stiffness (both trains engaged in parallel give Table 1's value), b = the
backlash per train at the axis (21° at the motor shaft / N), ct = 2ζ√(k_total·J)/2.

``drive_model = "rigid"``: both rotors rigidly geared to the axis (φk = Nθ): no backlash, no
compliance, inertia J + 2JmN². Faster; for runs where the drive train is not the subject.

Integrator: second-order exponential midpoint (shared/notes/FACTS.md), per substep h:

1. predictor to t + h/2: mesh torques and currents at t; z by an exponential half step with the
   decay rate a = |ω|/g(ω) of the previous step's midpoint; explicit half step for rates and angles;
2. with every coefficient frozen at the midpoint state: currents advanced exactly (exponential,
   clamped at 0 with the exact zero-crossing time), z advanced exactly
   (z → z∞ + (z − z∞)e^{−ah}, z∞ = ω½/a); the ω update uses the *step means* of the currents and
   of σ0 z, σ1 dz/dt = σ1 Δz/h, and σ2 trapezoidally (implicit); mesh torques and additive
   effects at the midpoint; angles by the trapezoid rule.

Pure Python floats and ``math``; no wall clock, no threads, deterministic.
"""

from __future__ import annotations

import math

from plant.friction import LuGre, lugre_from_parameters
from plant.params import AxisParameters

__all__ = ["AxisPlant", "ARCSEC_PER_RAD"]

ARCSEC_PER_RAD = 180.0 / math.pi * 3600.0
_TWO_PI = 2.0 * math.pi


def _build_effects(params: AxisParameters, extra) -> list:
    effects = []
    if params.effects:
        from plant.effects import build_effect

        effects.extend(build_effect(dict(spec)) for spec in params.effects)
    if extra:
        effects.extend(extra)
    return effects


class AxisPlant:
    """One telescope axis (RA or DEC) driven by two one-way torque motors.

    Parameters
    ----------
    params : AxisParameters
        From :func:`plant.params.load_parameters` (``params.axes["ra"]``).
    name : str, optional
        Label (default ``params.name``).
    effects : list of plant.effects.Effect, optional
        Extra effect objects, in addition to those built from ``params.effects`` with
        :func:`plant.effects.build_effect`. Additive kinds (``position_periodic``,
        ``gravity_imbalance``, ``time_periodic``) add ``torque_nm(θ, ω, t)`` to the load;
        ``asymmetric_friction`` sets Tc/σ2 per direction, ``presliding`` sets σ0/σ1, ``backlash``
        sets each train's dead-zone width to ``width_rad`` (at the axis).

    Attributes
    ----------
    now_us : int
        Plant time [µs].
    axis_angle_rad, axis_rate_rad_s : float
        Truth (tests and reports only; boards read the encoders).
    z_rad : float
        LuGre bristle deflection [rad].
    friction : LuGre
        The resolved friction parameters in use.
    perfect : bool
        ``params.perfect``: no backlash, friction σ2·ω only, no effects, no encoder error.

    Notes
    -----
    Motor A pushes +, motor B pushes −; duties are 0..1 (paper §3.3). Currents are never limited
    (the 6 A rating of §3.2 is reported, not enforced: see ``current_over_rating_us``).
    """

    def __init__(self, params: AxisParameters, name: str | None = None, effects=None) -> None:
        self.params = params
        self.name = name if name is not None else params.name
        self.perfect = bool(params.perfect)
        self.effects = [] if self.perfect else _build_effects(params, effects)
        self._additive = [e for e in self.effects if getattr(e, "additive", True)]
        self.friction: LuGre = lugre_from_parameters(params.friction, self.effects)
        m, g = params.motor, params.gear
        self.rigid = params.drive_model == "rigid"
        self._n = g.ratio
        self._inv_n = 1.0 / g.ratio
        self._j = params.inertia_kg_m2
        self._jm = m.rotor_inertia_kg_m2
        self._cm = m.viscous_nm_s_rad
        self._r = m.resistance_ohm
        self._l = m.inductance_h
        self._k = m.torque_constant_nm_a
        self._vs = m.supply_v
        self._shunt = m.shunt_ohm
        self._rated = m.rated_current_a
        self._kt = g.train_stiffness_nm_rad
        self._ct = g.damping_ratio * math.sqrt(g.stiffness_nm_rad * params.inertia_kg_m2)  # 2ζ√(kJ)/2
        width = g.backlash_rad
        for e in self.effects:
            if getattr(e, "kind", "") == "backlash":
                width = float(e.width_rad)
        if self.perfect or self.rigid:
            width = 0.0
        self.backlash_rad = width
        self._hb = 0.5 * width
        self.max_substep_us = int(params.max_substep_us)
        enc = params.encoders
        self._qei_scale = enc.counts_per_axis_rev / _TWO_PI
        self._roller = enc.roller_ratio
        self._enc_err_rad = 0.0 if self.perfect else enc.incremental_error_arcsec / ARCSEC_PER_RAD
        self._abs_counts = 1 << enc.absolute_bits
        self._coef_cache: dict[int, tuple] = {}
        self.now_us = 0
        self.duty_a = 0.0
        self.duty_b = 0.0
        self.reset()

    # ------------------------------------------------------------------ control inputs

    def set_duties(self, duty_a: float, duty_b: float) -> None:
        """Set the two PWM duties, held until the next call (zero-order hold).

        Parameters
        ----------
        duty_a, duty_b : float
            0..1; motor A pushes +, motor B pushes −. Values outside are clamped.

        Raises
        ------
        ValueError
            A duty is NaN.
        """
        if duty_a != duty_a or duty_b != duty_b:
            raise ValueError(f"{self.name}: duty is NaN ({duty_a!r}, {duty_b!r})")
        self.duty_a = 0.0 if duty_a < 0.0 else (1.0 if duty_a > 1.0 else float(duty_a))
        self.duty_b = 0.0 if duty_b < 0.0 else (1.0 if duty_b > 1.0 else float(duty_b))

    def reset(self, angle_rad: float = 0.0) -> None:
        """Put the axis at rest at ``angle_rad`` with both trains just touching their drive flanks.

        Currents, rates and the bristle state are zeroed; train A sits on its + flank and train B on
        its − flank with zero force (the preloaded contact state). ``now_us`` is kept (plant time
        does not restart); the over-current statistics are cleared.
        """
        self.axis_angle_rad = float(angle_rad)
        self.axis_rate_rad_s = 0.0
        self.z_rad = 0.0
        self.motor_a_angle_rad = (angle_rad + self._hb) * self._n
        self.motor_b_angle_rad = (angle_rad - self._hb) * self._n
        self.motor_a_rate_rad_s = 0.0
        self.motor_b_rate_rad_s = 0.0
        self.current_a_a = 0.0
        self.current_b_a = 0.0
        self._a_prev = 0.0
        self._load_prev = 0.0
        self.friction_torque_nm = 0.0
        self.gear_torque_nm = (0.0, 0.0)
        self.peak_current_a = (0.0, 0.0)
        self.current_over_rating_us = (0, 0)

    # ------------------------------------------------------------------ integration

    @staticmethod
    def mesh_torque_nm(d_rad: float, rel_rate_rad_s: float, kt: float, ct: float, hb: float) -> float:
        """Torque one gear train applies to the axis (the law ``_substep`` inlines).

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
            0 inside the dead zone; outside it, spring plus damper, clipped so that the teeth
            only push (never pull) [N·m].
        """
        if d_rad > hb:
            return max(0.0, kt * (d_rad - hb) + ct * rel_rate_rad_s)
        if d_rad < -hb:
            return min(0.0, kt * (d_rad + hb) + ct * rel_rate_rad_s)
        return 0.0

    def _coefs(self, h_us: int) -> tuple:
        c = self._coef_cache.get(h_us)
        if c is None:
            h = h_us * 1e-6
            rl = self._r / self._l
            er = math.exp(-rl * h)
            c = (h, 0.5 * h, rl, er, (1.0 - er) / (rl * h))
            self._coef_cache[h_us] = c
        return c

    def advance_to(self, t_us: int) -> None:
        """Integrate from ``now_us`` to ``t_us`` in substeps of at most ``max_substep_us``.

        Parameters
        ----------
        t_us : int
            Target plant time [µs], >= ``now_us``.

        Raises
        ------
        ValueError
            ``t_us`` is before ``now_us``.
        """
        t_us = int(t_us)
        now = self.now_us
        if t_us < now:
            raise ValueError(f"{self.name}: advance_to({t_us}) is before now_us={now}")
        if (self.duty_a == 0.0 and self.duty_b == 0.0 and self.axis_rate_rad_s == 0.0
                and self.motor_a_rate_rad_s == 0.0 and self.motor_b_rate_rad_s == 0.0
                and self.current_a_a == 0.0 and self.current_b_a == 0.0 and self.z_rad == 0.0
                and self.gear_torque_nm == (0.0, 0.0) and self._load_prev == 0.0
                and not self._additive):
            # Exact equilibrium: undriven, at rest, no bristle deflection, no gear or load torque.
            # Every derivative is exactly zero, so integrating would return the same state bit for
            # bit; skipping it is exact (an axis that never moved, e.g. DEC while RA tracks).
            self.now_us = t_us
            return
        step = self.max_substep_us
        step_fn = self._substep_rigid if self.rigid else self._substep
        while now < t_us:
            h_us = t_us - now
            if h_us > step:
                h_us = step
            step_fn(now, h_us)
            now += h_us
            self.now_us = now

    def _load(self, th: float, w: float, t_s: float) -> float:
        total = 0.0
        for e in self._additive:
            total += e.torque_nm(th, w, t_s)
        return total

    def _substep(self, t0_us: int, h_us: int) -> None:
        h, hh, rl, er, fr = self._coefs(h_us)
        fr_ = self.friction
        s0 = fr_.sigma0_nm_rad
        s1 = fr_.sigma1_nm_s_rad
        n_inv = self._inv_n
        jm = self._jm
        cm = self._cm
        k = self._k
        kt = self._kt
        ct = self._ct
        hb = self._hb
        j = self._j
        th = self.axis_angle_rad
        w = self.axis_rate_rad_s
        z = self.z_rad
        pa = self.motor_a_angle_rad
        pb = self.motor_b_angle_rad
        wa = self.motor_a_rate_rad_s
        wb = self.motor_b_rate_rad_s
        ia = self.current_a_a
        ib = self.current_b_a

        # ---- stage 1: predictor to the midpoint
        # The mesh torque of each train (spring kt with dead zone ±hb plus damping ct, pushing
        # only, see mesh_torque_nm) is inlined here and in stage 2 on purpose: this is the hot
        # loop and a call per train and stage costs ~10 % of the plant's time.
        d = pa * n_inv - th
        if d > hb:
            ta = kt * (d - hb) + ct * (wa * n_inv - w)
            if ta < 0.0:
                ta = 0.0
        elif d < -hb:
            ta = kt * (d + hb) + ct * (wa * n_inv - w)
            if ta > 0.0:
                ta = 0.0
        else:
            ta = 0.0
        d = pb * n_inv - th
        if d > hb:
            tb = kt * (d - hb) + ct * (wb * n_inv - w)
            if tb < 0.0:
                tb = 0.0
        elif d < -hb:
            tb = kt * (d + hb) + ct * (wb * n_inv - w)
            if tb > 0.0:
                tb = 0.0
        else:
            tb = 0.0
        if self.perfect:
            s2 = fr_.sigma2_pos_nm_s_rad if w >= 0.0 else fr_.sigma2_neg_nm_s_rad
            f = s2 * w
        else:
            a = self._a_prev
            x = a * hh
            if x > 0.0:
                zs = w / a
                om = -math.expm1(-x)
                zh = zs + (z - zs) * (1.0 - om)
                zbar = zs + (z - zs) * om / x
            else:
                zh = z + hh * w
                zbar = z + 0.5 * hh * w
            s2 = fr_.sigma2_pos_nm_s_rad if w >= 0.0 else fr_.sigma2_neg_nm_s_rad
            f = s0 * zbar + s1 * (zh - z) / hh + s2 * w
        w_h = w + hh * (ta + tb - f - self._load_prev) / j
        wa_h = wa + hh * (k * ia - ta * n_inv - cm * wa) / jm
        wb_h = wb + hh * (-k * ib - tb * n_inv - cm * wb) / jm
        th_h = th + hh * w
        pa_h = pa + hh * wa
        pb_h = pb + hh * wb

        # ---- stage 2: full step with coefficients frozen at the midpoint
        d = pa_h * n_inv - th_h
        if d > hb:
            ta = kt * (d - hb) + ct * (wa_h * n_inv - w_h)
            if ta < 0.0:
                ta = 0.0
        elif d < -hb:
            ta = kt * (d + hb) + ct * (wa_h * n_inv - w_h)
            if ta > 0.0:
                ta = 0.0
        else:
            ta = 0.0
        d = pb_h * n_inv - th_h
        if d > hb:
            tb = kt * (d - hb) + ct * (wb_h * n_inv - w_h)
            if tb < 0.0:
                tb = 0.0
        elif d < -hb:
            tb = kt * (d + hb) + ct * (wb_h * n_inv - w_h)
            if tb > 0.0:
                tb = 0.0
        else:
            tb = 0.0
        load = self._load(th_h, w_h, (t0_us + 0.5 * h_us) * 1e-6) if self._additive else 0.0

        # currents: exact exponential with ω frozen, diode clamp at 0
        r = self._r
        iss = (self.duty_a * self._vs - k * wa_h) / r
        ia1 = iss + (ia - iss) * er
        if ia1 >= 0.0:
            ia_m = iss + (ia - iss) * fr
        elif ia > 0.0:
            tz = math.log((ia - iss) / (-iss)) / rl
            ia_m = (iss * tz + ia / rl) / h
            ia1 = 0.0
        else:
            ia1 = ia_m = 0.0
        iss = (self.duty_b * self._vs + k * wb_h) / r
        ib1 = iss + (ib - iss) * er
        if ib1 >= 0.0:
            ib_m = iss + (ib - iss) * fr
        elif ib > 0.0:
            tz = math.log((ib - iss) / (-iss)) / rl
            ib_m = (iss * tz + ib / rl) / h
            ib1 = 0.0
        else:
            ib1 = ib_m = 0.0

        wa1 = wa + h * (k * ia_m - ta * n_inv - cm * wa_h) / jm
        wb1 = wb + h * (-k * ib_m - tb * n_inv - cm * wb_h) / jm

        # friction: z exact with a = |ω½|/g(ω½), σ2 trapezoidal (implicit)
        if w_h >= 0.0:
            s2 = fr_.sigma2_pos_nm_s_rad
            tc = fr_.tc_pos_nm
        else:
            s2 = fr_.sigma2_neg_nm_s_rad
            tc = fr_.tc_neg_nm
        if self.perfect:
            z1 = 0.0
            fz = 0.0
            a = 0.0
        else:
            aw = -w_h if w_h < 0.0 else w_h
            if aw > 0.0:
                u = aw / fr_.omega_s_rad_s
                sg = tc + (fr_.ts_nm - tc) * math.exp(-(u * u if fr_.delta == 2.0 else u ** fr_.delta))
                a = aw * s0 / sg
                x = a * h
                zs = w_h / a
                om = -math.expm1(-x)
                z1 = zs + (z - zs) * (1.0 - om)
                zbar = zs + (z - zs) * om / x
            else:
                a = 0.0
                z1 = z
                zbar = z
            fz = s0 * zbar + s1 * (z1 - z) / h
        w1 = (j * w + h * (ta + tb - fz - load) - hh * s2 * w) / (j + hh * s2)

        self.axis_angle_rad = th + hh * (w + w1)
        self.axis_rate_rad_s = w1
        self.z_rad = z1
        self.motor_a_angle_rad = pa + hh * (wa + wa1)
        self.motor_b_angle_rad = pb + hh * (wb + wb1)
        self.motor_a_rate_rad_s = wa1
        self.motor_b_rate_rad_s = wb1
        self.current_a_a = ia1
        self.current_b_a = ib1
        self._a_prev = a
        self._load_prev = load
        self.friction_torque_nm = fz + 0.5 * s2 * (w + w1)
        self.gear_torque_nm = (ta, tb)
        rated = self._rated
        if ia1 > rated or ib1 > rated:
            self._overcurrent(ia1, ib1, h_us)

    def _overcurrent(self, ia: float, ib: float, h_us: int) -> None:
        pa, pb = self.peak_current_a
        if ia <= pa and ib <= pb and ia <= self._rated and ib <= self._rated:
            return  # nothing to record (the common case; keeps the substep cheap)
        oa, ob = self.current_over_rating_us
        rated = self._rated
        if ia > rated:
            oa += h_us
        if ib > rated:
            ob += h_us
        self.peak_current_a = (max(pa, ia), max(pb, ib))
        self.current_over_rating_us = (oa, ob)

    def _substep_rigid(self, t0_us: int, h_us: int) -> None:
        """Rigid drive: φk = Nθ, inertia J + 2JmN², motor drag reflected (cm N² each)."""
        h, hh, rl, er, fr = self._coefs(h_us)
        fr_ = self.friction
        s0 = fr_.sigma0_nm_rad
        s1 = fr_.sigma1_nm_s_rad
        n = self._n
        k = self._k
        kn = k * n
        j = self._j + 2.0 * self._jm * n * n
        cmr = 2.0 * self._cm * n * n
        th = self.axis_angle_rad
        w = self.axis_rate_rad_s
        z = self.z_rad
        ia = self.current_a_a
        ib = self.current_b_a
        if self.perfect:
            s2 = fr_.sigma2_pos_nm_s_rad if w >= 0.0 else fr_.sigma2_neg_nm_s_rad
            f = s2 * w
        else:
            a = self._a_prev
            x = a * hh
            if x > 0.0:
                zs = w / a
                om = -math.expm1(-x)
                zh = zs + (z - zs) * (1.0 - om)
                zbar = zs + (z - zs) * om / x
            else:
                zh = z + hh * w
                zbar = z + 0.5 * hh * w
            s2 = fr_.sigma2_pos_nm_s_rad if w >= 0.0 else fr_.sigma2_neg_nm_s_rad
            f = s0 * zbar + s1 * (zh - z) / hh + s2 * w
        w_h = w + hh * (kn * (ia - ib) - f - cmr * w - self._load_prev) / j
        th_h = th + hh * w
        load = self._load(th_h, w_h, (t0_us + 0.5 * h_us) * 1e-6) if self._additive else 0.0
        r = self._r
        wm = n * w_h
        iss = (self.duty_a * self._vs - k * wm) / r
        ia1 = iss + (ia - iss) * er
        if ia1 >= 0.0:
            ia_m = iss + (ia - iss) * fr
        elif ia > 0.0:
            tz = math.log((ia - iss) / (-iss)) / rl
            ia_m = (iss * tz + ia / rl) / h
            ia1 = 0.0
        else:
            ia1 = ia_m = 0.0
        iss = (self.duty_b * self._vs + k * wm) / r
        ib1 = iss + (ib - iss) * er
        if ib1 >= 0.0:
            ib_m = iss + (ib - iss) * fr
        elif ib > 0.0:
            tz = math.log((ib - iss) / (-iss)) / rl
            ib_m = (iss * tz + ib / rl) / h
            ib1 = 0.0
        else:
            ib1 = ib_m = 0.0
        if w_h >= 0.0:
            s2 = fr_.sigma2_pos_nm_s_rad
            tc = fr_.tc_pos_nm
        else:
            s2 = fr_.sigma2_neg_nm_s_rad
            tc = fr_.tc_neg_nm
        s2 += cmr
        if self.perfect:
            z1 = 0.0
            fz = 0.0
            a = 0.0
        else:
            aw = -w_h if w_h < 0.0 else w_h
            if aw > 0.0:
                u = aw / fr_.omega_s_rad_s
                sg = tc + (fr_.ts_nm - tc) * math.exp(-(u * u if fr_.delta == 2.0 else u ** fr_.delta))
                a = aw * s0 / sg
                x = a * h
                zs = w_h / a
                om = -math.expm1(-x)
                z1 = zs + (z - zs) * (1.0 - om)
                zbar = zs + (z - zs) * om / x
            else:
                a = 0.0
                z1 = z
                zbar = z
            fz = s0 * zbar + s1 * (z1 - z) / h
        ta = kn * ia_m
        tb = -kn * ib_m
        w1 = (j * w + h * (ta + tb - fz - load) - hh * s2 * w) / (j + hh * s2)
        th1 = th + hh * (w + w1)
        self.axis_angle_rad = th1
        self.axis_rate_rad_s = w1
        self.z_rad = z1
        self.motor_a_angle_rad = self.motor_b_angle_rad = th1 * n
        self.motor_a_rate_rad_s = self.motor_b_rate_rad_s = w1 * n
        self.current_a_a = ia1
        self.current_b_a = ib1
        self._a_prev = a
        self._load_prev = load
        self.friction_torque_nm = fz + 0.5 * (s2 - cmr) * (w + w1)
        self.gear_torque_nm = (ta, tb)
        rated = self._rated
        if ia1 > rated or ib1 > rated:
            self._overcurrent(ia1, ib1, h_us)

    # ------------------------------------------------------------------ sensors

    def qei_counts(self) -> int:
        """Incremental encoder count (cumulative, signed) at the current plant time.

        ``floor((θ + e(θ)) · 24.5 · 4 608 000 / 2π)``: Gurley 8×60, 4.608e6 counts/rev (paper §3.2)
        through the 1:24.5 friction roller (§2.2), 0.01148″ per count. ``e`` is the optional
        once-per-encoder-revolution error (``incremental_error_arcsec``, default 0).

        Returns
        -------
        int
        """
        th = self.axis_angle_rad
        if self._enc_err_rad:
            th += self._enc_err_rad * math.sin(th * self._roller)
        return math.floor(th * self._qei_scale)

    def absolute_counts(self) -> int:
        """29-bit absolute encoder word on the axis (RCN 829, paper §3.2): 0 .. 2**29 − 1.

        ``floor((θ mod 2π) / 2π · 2**29)``; wraps once per axis revolution.
        """
        n = self._abs_counts
        c = math.floor((self.axis_angle_rad % _TWO_PI) / _TWO_PI * n)
        return c if c < n else n - 1

    def shunt_voltage_v(self, motor: str) -> float:
        """Voltage across the 0.1 Ω shunt of motor ``"a"`` or ``"b"`` [V] = i · 0.1 Ω (i >= 0).

        The averaged armature current (no PWM ripple); the firmware samples at the PWM falling edge
        where the real current peaks (paper §3.3).

        Raises
        ------
        ValueError
            ``motor`` is not ``"a"`` or ``"b"``.
        """
        if motor == "a":
            return self.current_a_a * self._shunt
        if motor == "b":
            return self.current_b_a * self._shunt
        raise ValueError(f"{self.name}: motor must be 'a' or 'b', got {motor!r}")

    # ------------------------------------------------------------------ truth for tests/reports

    @property
    def motor_current_a(self) -> tuple[float, float]:
        """(i_a, i_b) armature currents [A], >= 0."""
        return (self.current_a_a, self.current_b_a)

    @property
    def motor_angle_rad(self) -> tuple[float, float]:
        """(φa, φb) motor shaft angles [rad]."""
        return (self.motor_a_angle_rad, self.motor_b_angle_rad)

    @property
    def motor_rate_rad_s(self) -> tuple[float, float]:
        """(ωa, ωb) motor shaft rates [rad/s]."""
        return (self.motor_a_rate_rad_s, self.motor_b_rate_rad_s)

    @property
    def axis_rate_arcsec_s(self) -> float:
        """Axis rate [″/s]."""
        return self.axis_rate_rad_s * ARCSEC_PER_RAD

    def state(self) -> tuple[float, ...]:
        """(θ, ω, z, φa, ωa, ia, φb, ωb, ib): the full state vector (SI), for tests and references."""
        return (
            self.axis_angle_rad, self.axis_rate_rad_s, self.z_rad,
            self.motor_a_angle_rad, self.motor_a_rate_rad_s, self.current_a_a,
            self.motor_b_angle_rad, self.motor_b_rate_rad_s, self.current_b_a,
        )

    def stored_energy_j(self) -> float:
        """Kinetic + gear-spring + magnetic + bristle energy [J] (twin-train model)."""
        j, jm, kt, hb, n_inv = self._j, self._jm, self._kt, self._hb, self._inv_n
        e = 0.5 * j * self.axis_rate_rad_s ** 2
        e += 0.5 * jm * (self.motor_a_rate_rad_s ** 2 + self.motor_b_rate_rad_s ** 2)
        e += 0.5 * self._l * (self.current_a_a ** 2 + self.current_b_a ** 2)
        for p in (self.motor_a_angle_rad, self.motor_b_angle_rad):
            d = p * n_inv - self.axis_angle_rad
            x = d - hb if d > hb else (d + hb if d < -hb else 0.0)
            e += 0.5 * kt * x * x
        if not self.perfect:
            e += 0.5 * self.friction.sigma0_nm_rad * self.z_rad ** 2
        return e
