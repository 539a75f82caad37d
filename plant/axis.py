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

The substeps run in :mod:`plant.kernel`: plain Python functions of float tuples, compiled with
numba when it is installed (``SCHMIDT_FIL_JIT=0`` runs them interpreted). No wall clock, no
threads, deterministic. Parameters are packed once at construction: change them through
:func:`plant.params.load_parameters` overrides and build a new plant, not by assigning
attributes.
"""

from __future__ import annotations

import math
import random
from typing import Any, Final

from bus.jit_entry import entry_point  # a leaf of bus (standard library only), as bus.units
from bus.units import ARCSEC_PER_RAD  # a constants leaf of bus
from plant import kernel
from plant.effects import Backlash
from plant.gear_train_disturbance import line_rows, lines_table
from plant.friction import LuGre, lugre_from_parameters
from plant.params import AxisParameters

__all__ = ["AxisPlant", "ARCSEC_PER_RAD"]

_TWO_PI: Final = 2.0 * math.pi


def _build_effects(params: AxisParameters, extra) -> list:
    effects: list = []
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

    def __init__(self, params: AxisParameters, name: str | None = None, effects=None, seed: int = 0) -> None:
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
            if getattr(e, "kind", "") == Backlash.kind:
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
        # issue 12: motor tachometers (CP-850) and the auxiliary encoder (A25S through 1:10.8)
        self._tach_scale = params.tachometer.counts_per_rev / _TWO_PI
        ax = params.aux_encoder
        self._aux_r = ax.reduction
        self._aux_n = 1 << ax.bits
        off = self.perfect
        self._aux_e1 = 0.0 if off else ax.once_per_rev_arcsec / ARCSEC_PER_RAD
        self._aux_e2 = 0.0 if off else ax.twice_per_rev_arcsec / ARCSEC_PER_RAD
        self._aux_p1, self._aux_p2 = ax.once_per_rev_phase_rad, ax.twice_per_rev_phase_rad
        self._aux_sigma = 0.0 if off else ax.noise_arcsec / ARCSEC_PER_RAD
        #: seed of the auxiliary encoder's read noise (the scenario's seed, see host/network.py)
        self.seed = int(seed)
        self._aux_rng = random.Random(f"aux-encoder/{self.name}/{self.seed}")
        # gear-train torque lines (plant/gear_train_disturbance.py); empty table = none
        gd = None if self.perfect else params.gear_disturbance
        self._lines = lines_table(gd)
        # interpreted kernel: plain tuples index ≈ 10x faster than numpy elements (same numbers)
        self._lines_k = self._lines if kernel.JIT else tuple(tuple(float(v) for v in r) for r in self._lines)
        #: The gear-train torque lines this plant runs with (plant/gear_train_disturbance.py), one dict per line.
        self.gear_lines = line_rows(gd)
        self._p = kernel.pack_parameters(
            n=self._n, jm=self._jm, cm=self._cm, k=self._k, kt=self._kt, ct=self._ct, hb=self._hb,
            j=self._j, r=self._r, l=self._l, vs=self._vs, friction=self.friction,
            perfect=self.perfect, rated=self._rated)
        self.now_us = 0
        self.duty_a = 0.0
        self.duty_b = 0.0
        #: the kernel's substep loop, resolved at the first advance (:meth:`_resolve_run`)
        self._run: Any = None
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
        """The torque one gear train applies to the axis [N·m]: :func:`plant.kernel.mesh_torque_nm`
        (a method, not a class attribute holding the function: the class is compiled by mypyc)."""
        return float(kernel.mesh_torque_nm(d_rad, rel_rate_rad_s, kt, ct, hb))

    def state_tuple(self) -> tuple:
        """The kernel state ``X`` (see :mod:`plant.kernel`): the 9 states plus the step memory."""
        return (self.axis_angle_rad, self.axis_rate_rad_s, self.z_rad,
                self.motor_a_angle_rad, self.motor_a_rate_rad_s, self.current_a_a,
                self.motor_b_angle_rad, self.motor_b_rate_rad_s, self.current_b_a,
                self._a_prev, self._load_prev)

    def _set_state(self, X: tuple) -> None:
        (self.axis_angle_rad, self.axis_rate_rad_s, self.z_rad,
         self.motor_a_angle_rad, self.motor_a_rate_rad_s, self.current_a_a,
         self.motor_b_angle_rad, self.motor_b_rate_rad_s, self.current_b_a,
         self._a_prev, self._load_prev) = X

    def advance_to(self, t_us: int) -> None:
        """Integrate from ``now_us`` to ``t_us`` in substeps of at most ``max_substep_us``.

        The substeps run in :mod:`plant.kernel` (numba-compiled when available). With additive
        load effects (Python objects) the substep loop runs here instead, calling the kernel's
        two stages and evaluating the effects at each midpoint.

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
        if t_us <= now:
            if t_us < now:
                raise ValueError(f"{self.name}: advance_to({t_us}) is before now_us={now}")
            return
        if (self.duty_a == 0.0 and self.duty_b == 0.0 and self.axis_rate_rad_s == 0.0
                and self.motor_a_rate_rad_s == 0.0 and self.motor_b_rate_rad_s == 0.0
                and self.current_a_a == 0.0 and self.current_b_a == 0.0 and self.z_rad == 0.0
                and self.gear_torque_nm == (0.0, 0.0) and self._load_prev == 0.0
                and not self._additive and self._lines.shape[0] == 0):
            # Exact equilibrium: undriven, at rest, no bristle deflection, no gear or load torque.
            # Every derivative is exactly zero, so integrating would return the same state bit for
            # bit; skipping it is exact (an axis that never moved, e.g. DEC while RA tracks).
            self.now_us = t_us
            return
        if self._additive:
            out = self._run_with_effects(now, t_us)
        else:
            run = self._run
            if run is None:
                run = self._run = self._resolve_run()
            if self._lines.shape[0]:
                out = run(self.state_tuple(), self._p, self._lines_k, self.duty_a, self.duty_b, t_us - now,
                          self.max_substep_us)
            else:
                out = run(self.state_tuple(), self._p, self.duty_a, self.duty_b, t_us - now,
                          self.max_substep_us)
        X, ta, tb, ff, peak_a, peak_b, over_a, over_b = out
        self._set_state(X)
        self.now_us = t_us
        self.gear_torque_nm = (ta, tb)
        self.friction_torque_nm = ff
        pa, pb = self.peak_current_a
        if peak_a > pa or peak_b > pb:
            self.peak_current_a = (max(pa, peak_a), max(pb, peak_b))
        if over_a or over_b:
            oa, ob = self.current_over_rating_us
            self.current_over_rating_us = (oa + over_a, ob + over_b)

    def _resolve_run(self) -> Any:
        """The kernel's substep loop for this plant (rigid or twin, with or without gear lines),
        as the compiled entry point for its argument types (:func:`bus.jit_entry.entry_point`:
        no numba type dispatch per call; the plant's argument types never change)."""
        lines = self._lines.shape[0] > 0
        if self.rigid:
            fn = kernel.rigid_run_lines if lines else kernel.rigid_run
        else:
            fn = kernel.twin_run_lines if lines else kernel.twin_run
        state = tuple(float(v) for v in self.state_tuple())
        head = (state, self._p, self._lines_k) if lines else (state, self._p)
        return entry_point(fn, head + (0.0, 0.0, 1, max(1, self.max_substep_us)))

    def _run_with_effects(self, now: int, t_us: int) -> tuple:
        """The kernel's substep loop with the additive load evaluated at each midpoint (Python)."""
        midpoint, finish = ((kernel.rigid_midpoint, kernel.rigid_finish) if self.rigid
                            else (kernel.twin_midpoint, kernel.twin_finish))
        P = self._p
        lines = self._lines_k
        lines_n = len(lines)
        rl = P[9]
        rated = self._rated
        X = self.state_tuple()
        peak_a, peak_b = X[5], X[8]
        over_a = over_b = 0
        ta = tb = ff = 0.0
        step = self.max_substep_us
        while now < t_us:
            h_us = min(step, t_us - now)
            h = h_us * 1e-6
            er = math.exp(-rl * h)
            fr = (1.0 - er) / (rl * h)
            M = midpoint(X, P, h)
            t_mid_s = (now + 0.5 * h_us) * 1e-6
            load = 0.0
            for e in self._additive:
                load += e.torque_nm(M[0], M[1], t_mid_s)
            if lines_n:
                if self.rigid:
                    load += kernel.gear_lines_torque_nm(M[0], M[0], M[0], lines)
                else:
                    load += kernel.gear_lines_torque_nm(M[0], M[2] * P[0], M[4] * P[0], lines)
            X, ta, tb, ff = finish(X, M, P, self.duty_a, self.duty_b, h, er, fr, load)
            peak_a, peak_b = max(peak_a, X[5]), max(peak_b, X[8])
            if X[5] > rated:
                over_a += h_us
            if X[8] > rated:
                over_b += h_us
            now += h_us
        return X, ta, tb, ff, peak_a, peak_b, over_a, over_b

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

    # -- issue 12: motor tachometers and the auxiliary encoder ------------------------------------
    def tach_counts(self, motor: str) -> int:
        """Count of the CP-850 incremental encoder on motor ``"a"`` or ``"b"`` (cumulative, signed)
        at the current plant time: ``floor(φk · counts_per_rev / 2π)`` (paper §3.2; resolution:
        ``tachometer.counts_per_rev``). Ideal encoder (no line error).

        Raises
        ------
        ValueError
            ``motor`` is not ``"a"`` or ``"b"``.
        """
        if motor == "a":
            return math.floor(self.motor_a_angle_rad * self._tach_scale)
        if motor == "b":
            return math.floor(self.motor_b_angle_rad * self._tach_scale)
        raise ValueError(f"{self.name}: motor must be 'a' or 'b', got {motor!r}")

    def aux_encoder_angle_rad(self) -> float:
        """True angle of the auxiliary encoder's shaft [rad]: ``reduction · θ`` (ideal 1:10.8
        reduction: no backlash or transmission error; encoder zero at axis zero). Multi-turn."""
        return self.axis_angle_rad * self._aux_r

    def aux_encoder_word(self) -> int:
        """The 17-bit single-turn word of the auxiliary encoder (Gurley A25S, paper §3.2) at the
        current plant time, 0 .. 2**bits − 1.

        ``floor(((φe + e(φe)) mod 2π) / 2π · 2**bits)`` with ``φe = reduction · θ`` and
        ``e = a1 sin(φe + p1) + a2 sin(2φe + p2) + n``, ``n`` ~ N(0, noise) drawn from a generator
        seeded with the axis name and :attr:`seed` (one draw per read: a run is reproducible for
        the same read sequence). ``perfect`` turns every error term off.
        """
        phi = self.axis_angle_rad * self._aux_r
        e = 0.0
        if self._aux_e1:
            e += self._aux_e1 * math.sin(phi + self._aux_p1)
        if self._aux_e2:
            e += self._aux_e2 * math.sin(2.0 * phi + self._aux_p2)
        if self._aux_sigma:
            e += self._aux_rng.gauss(0.0, self._aux_sigma)
        n = self._aux_n
        c = math.floor(((phi + e) % _TWO_PI) / _TWO_PI * n)
        return c if c < n else n - 1
    # -- end issue 12 --------------------------------------------------------------------------

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
