"""Brushed DC torque motor on a low-side MOSFET (paper §3.2, §3.3, eq. 1).

    v = L di/dt + R i + K ω_push          (eq. 1; Kt = Ke = K in SI)

Drive topology (paper §3.3): the motor sits between +24 V and the drain of an IRF250; the source
goes to ground through the 0.1 Ω shunt. Each motor can therefore only push one way: motor A pushes
the axis positive, motor B negative. ``ω_push`` is the motor's rate measured in its own push
direction (``+ω_motor`` for A, ``−ω_motor`` for B).

Simplification (stated): the PWM is averaged, ``v = duty · 24 V``, which holds while the current
conducts continuously through the MOSFET (on) and the freewheel diode across the motor (off).
The current cannot reverse (MOSFET blocks, diode conducts one way), so ``i >= 0``: when the
averaged equation would drive i below zero it is clamped at 0 (discontinuous conduction; the
terminal voltage is then the back-EMF, which is not modelled further). A reverse current would need
the back-EMF to exceed the supply (ω_push < −(24 V)/K ≈ −69 rad/s at the motor, ≈ 11°/s at the axis,
beyond the slew speed), through the MOSFET body diode; it is not modelled. The shunt's 0.1 Ω and the
MOSFET's R_DS(on) are neglected in the loop (R is the armature resistance). PWM ripple, commutation
ripple, brush drop and temperature are not modelled (docs/plant.md, Limitations).

The axis integrator inlines :func:`current_step` for speed; this module is its reference.
"""

from __future__ import annotations

import math

__all__ = ["current_step", "steady_current_a"]


def steady_current_a(duty: float, omega_push_rad_s: float, resistance_ohm: float, torque_constant_nm_a: float,
                     supply_v: float) -> float:
    """Steady armature current [A] at constant duty and rate: max(0, (duty·V − K ω_push)/R)."""
    return max(0.0, (duty * supply_v - torque_constant_nm_a * omega_push_rad_s) / resistance_ohm)


def current_step(i0_a: float, duty: float, omega_push_rad_s: float, h_s: float, resistance_ohm: float,
                 inductance_h: float, torque_constant_nm_a: float, supply_v: float) -> tuple[float, float]:
    """Advance the armature current exactly over ``h_s`` with ω frozen; clamp at 0 (diode).

    Parameters
    ----------
    i0_a : float
        Current at the start [A], >= 0.
    duty : float
        PWM duty 0..1.
    omega_push_rad_s : float
        Motor rate in its push direction [rad/s], held constant over the step.
    h_s : float
        Step [s], > 0.
    resistance_ohm, inductance_h, torque_constant_nm_a, supply_v : float
        Motor constants (see :class:`plant.params.MotorParameters`).

    Returns
    -------
    (i1_a, i_mean_a) : tuple of float
        Current at the end of the step and its mean over the step [A].
    """
    r = resistance_ohm / inductance_h
    i_ss = (duty * supply_v - torque_constant_nm_a * omega_push_rad_s) / resistance_ohm
    e = math.exp(-r * h_s)
    i1 = i_ss + (i0_a - i_ss) * e
    if i1 >= 0.0:
        return i1, i_ss + (i0_a - i_ss) * (1.0 - e) / (r * h_s)
    if i0_a <= 0.0:
        return 0.0, 0.0
    t_zero = math.log((i0_a - i_ss) / (-i_ss)) / r  # the current reaches 0 at t_zero < h_s
    return 0.0, (i_ss * t_zero + i0_a / r) / h_s
