"""PI gains of the axis controller from the plant model through a documented tuning rule.

The paper (§4) reflects the axis at the motor shaft, keeps only viscous friction and the
armature (eq. 6), adds the dead time Δt/2 that discretisation introduces, and applies "standard
tuning rules of PI control" for a second-order-plus-dead-time (SOPDT) model, citing O'Dwyer's
handbook (paper ref. 15). The rule used here is Skogestad's SIMC rule (S. Skogestad, "Simple
analytic rules for model reduction and PID controller tuning", J. Process Control 13 (2003)
291-309; SIMC is tabulated in O'Dwyer's handbook family) with the "half rule":

1. Eq. 6 at the motor shaft: J_r = J/N² + J_rotor, σ2_r = σ2/N²;
   ω/V = (K/(J_r L)) / (s² + (R/L + σ2_r/J_r) s + (R σ2_r + K²)/(J_r L)).
   Its DC gain is K/(R σ2_r + K²) (rad/s per V) and its two real poles give τ1 ≥ τ2.
2. Input: the control effort U (duty) gives V = U·V_supply on the forward motor and p·U on the
   counter motor; by superposition (§3.3) the net is (1 − p)·U·V_supply.
3. Output: the firmware's measured variable is the *axis* rate in arcsec/s, so
   k = (1 − p)·V_supply·K/(R σ2_r + K²)/N·(648000/π)   [(″/s) per unit duty].
4. Dead time θ = Δt/2 from discretisation (the zero-order hold, paper §4) **plus** Δt/2 for
   the measurement: the firmware's rate is a QEI count difference over one tick, i.e. the mean
   rate over the last tick, which lags the true rate by Δt/2. Total θ = Δt by default
   (``include_measurement_lag=True``). With the paper's Δt/2 alone the sampled linear loop of
   the RA axis overshoots a rate step by ≈67 % (see tests/test_boards_control.py); with θ = Δt
   by ≈20 %, the usual SIMC behaviour when the dead time is modelled right.
5. Half rule: τ1' = τ1 + τ2/2, θ' = θ + τ2/2 (first-order-plus-dead-time equivalent).
6. SIMC PI: Kc = τ1'/(k (τc + θ')), τI = min(τ1', 4 (τc + θ')), with τc = θ' ("tight control").
7. Incremental discrete form of §4: Kp = Kc, Ki = Kc·Δt/τI (per tick).

Nothing here is fitted to a figure of the paper. ``boards/`` never imports ``plant/``: the
numbers come in as plain SI floats (``host/network.py`` reads them from the parameter file).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from bus.units import ARCSEC_PER_RAD, check_counter_fraction

__all__ = ["PiGains", "pi_gains_from_model", "design_axis_gains", "GAINS_SOURCE"]

#: How :func:`design_axis_gains` got its gains (written into the report).
GAINS_SOURCE = "boards.tuning.pi_gains_from_model (SIMC on the eq. 6 SOPDT model, low-preload σ2)"


@dataclass(frozen=True)
class PiGains:
    """Tuned gains and the intermediate model numbers (for the report).

    Attributes
    ----------
    kp : float
        Proportional gain, duty per (″/s) of axis rate.
    ki : float
        Integral gain per tick, duty per (″/s) per tick.
    kc : float
        Continuous proportional gain (= kp), duty per (″/s).
    tau_i_s : float
        Integral time, s.
    k : float
        Steady-state plant gain, (″/s of axis rate) per unit duty.
    k_motor_rad_s_per_v : float
        Eq. 6 DC gain at the motor shaft, rad/s per V.
    tau1_s, tau2_s : float
        Time constants of eq. 6 (τ1 ≥ τ2), s.
    theta_s : float
        Dead time θ (Δt/2 discretisation + Δt/2 measurement by default), s.
    tau1_eff_s, theta_eff_s : float
        Half-rule τ1' and θ', s.
    tau_c_s : float
        SIMC closed-loop time constant, s.
    tick_s : float
        Sampling period Δt, s.
    jr_kg_m2, sigma2r_nm_s_rad : float
        Reflected inertia and viscous friction at the motor shaft.
    """

    kp: float
    ki: float
    kc: float
    tau_i_s: float
    k: float
    k_motor_rad_s_per_v: float
    tau1_s: float
    tau2_s: float
    theta_s: float
    tau1_eff_s: float
    theta_eff_s: float
    tau_c_s: float
    tick_s: float
    jr_kg_m2: float
    sigma2r_nm_s_rad: float

    @property
    def kp_micro(self) -> int:
        """Kp in the AXIS_COMMAND SET_KP unit: micro-duty per (″/s), rounded."""
        return int(round(self.kp * 1e6))

    @property
    def ki_micro(self) -> int:
        """Ki in the SET_KI unit: micro-duty per (″/s) per tick, rounded."""
        return int(round(self.ki * 1e6))

    def as_dict(self) -> dict:
        """All fields as a plain dict."""
        return asdict(self)


def pi_gains_from_model(*, inertia_kg_m2: float, sigma2_nm_s_rad: float, gear_ratio: float,
                        r_ohm: float, l_h: float, k_nm_a: float, rotor_inertia_kg_m2: float,
                        counter_fraction: float, supply_v: float, tick_us: int,
                        tau_c_s: float | None = None,
                        include_measurement_lag: bool = True) -> PiGains:
    """SIMC PI gains for the twin-motor axis from the paper's eq. 6 SOPDT model.

    Parameters
    ----------
    inertia_kg_m2 : float
        Axis moment of inertia J, kg·m² (paper §4: 1.76e6 N·mm·s² = 1760 kg·m², RA).
    sigma2_nm_s_rad : float
        Axis viscous friction σ2, N·m·s/rad (Table 2: 6700 low preload).
    gear_ratio : float
        Motor-to-axis reduction N (360.489, §2.2).
    r_ohm, l_h : float
        Armature resistance (Ω) and inductance (H).
    k_nm_a : float
        Motor constant K (N·m/A = V·s/rad).
    rotor_inertia_kg_m2 : float
        Rotor inertia added at the motor shaft, kg·m²: pass the sum of both rotors
        (2 × per-motor value), since both turn with the axis.
    counter_fraction : float
        p, the counter-motor fraction of the drive law (0.10-0.25, §3.3).
    supply_v : float
        Motor supply, V (24, §3.3).
    tick_us : int
        Sampling period Δt, µs (5000).
    tau_c_s : float, optional
        SIMC closed-loop time constant; default θ' (tight control).
    include_measurement_lag : bool
        Add Δt/2 for the per-tick mean-rate measurement to the paper's Δt/2 (default True).

    Returns
    -------
    PiGains

    Raises
    ------
    ValueError
        For non-positive physical parameters or p outside [0, 1).
    """
    for name, v in (("inertia_kg_m2", inertia_kg_m2), ("gear_ratio", gear_ratio),
                    ("r_ohm", r_ohm), ("l_h", l_h), ("k_nm_a", k_nm_a),
                    ("supply_v", supply_v), ("tick_us", tick_us)):
        if not v > 0:
            raise ValueError(f"{name} must be > 0, got {v}")
    if sigma2_nm_s_rad < 0 or rotor_inertia_kg_m2 < 0:
        raise ValueError("sigma2_nm_s_rad and rotor_inertia_kg_m2 must be >= 0")
    check_counter_fraction(counter_fraction)

    n2 = gear_ratio * gear_ratio
    jr = inertia_kg_m2 / n2 + rotor_inertia_kg_m2
    s2r = sigma2_nm_s_rad / n2
    a1 = r_ohm / l_h + s2r / jr
    a0 = (r_ohm * s2r + k_nm_a ** 2) / (jr * l_h)
    k_motor = k_nm_a / (r_ohm * s2r + k_nm_a ** 2)
    disc = a1 * a1 - 4.0 * a0
    if disc >= 0.0:
        root = math.sqrt(disc)
        p_slow = (a1 - root) / 2.0        # magnitudes of the two real poles
        p_fast = (a1 + root) / 2.0
        tau1, tau2 = 1.0 / p_slow, 1.0 / p_fast
    else:                                  # underdamped: critically damped equivalent (documented)
        tau1 = tau2 = 1.0 / math.sqrt(a0)
    dt = tick_us * 1e-6
    theta = dt / 2.0 + (dt / 2.0 if include_measurement_lag else 0.0)
    tau1e = tau1 + tau2 / 2.0
    thetae = theta + tau2 / 2.0
    tc = thetae if tau_c_s is None else float(tau_c_s)
    k = (1.0 - counter_fraction) * supply_v * k_motor / gear_ratio * ARCSEC_PER_RAD
    kc = tau1e / (k * (tc + thetae))
    tau_i = min(tau1e, 4.0 * (tc + thetae))
    return PiGains(kp=kc, ki=kc * dt / tau_i, kc=kc, tau_i_s=tau_i, k=k,
                   k_motor_rad_s_per_v=k_motor, tau1_s=tau1, tau2_s=tau2, theta_s=theta,
                   tau1_eff_s=tau1e, theta_eff_s=thetae, tau_c_s=tc, tick_s=dt,
                   jr_kg_m2=jr, sigma2r_nm_s_rad=s2r)


def design_axis_gains(axis, counter_fraction: float, tick_us: int) -> PiGains:
    """The PI gains an axis controller runs, from the axis's plant parameters.

    Decision (paper §4 "Using the estimated parameters …"): the gains come from the
    **low-preload** friction set, since the paper tuned its PI for the reduced-preload model and
    kept the gains ("we preferred keeping the gains high"); running the high-preload scenario with
    the same controller is what Fig. 13(a)/(b) compare.

    Parameters
    ----------
    axis : plant.params.AxisParameters
        Read by attribute only (``inertia_kg_m2``, ``friction.low.sigma2_nm_s_rad``,
        ``gear.ratio``, ``motor.*``): ``boards`` never imports ``plant``.
    counter_fraction : float
        p the firmware runs (the scenario's override, else the parameter file's).
    tick_us : int
        Control tick [µs].

    Returns
    -------
    PiGains
    """
    m = axis.motor
    return pi_gains_from_model(
        inertia_kg_m2=axis.inertia_kg_m2, sigma2_nm_s_rad=axis.friction.low.sigma2_nm_s_rad,
        gear_ratio=axis.gear.ratio, r_ohm=m.resistance_ohm, l_h=m.inductance_h,
        k_nm_a=m.torque_constant_nm_a, rotor_inertia_kg_m2=2 * m.rotor_inertia_kg_m2,  # both rotors turn with the axis
        counter_fraction=counter_fraction, supply_v=m.supply_v, tick_us=tick_us,
    )
