"""The operator's steady-state duty–speed map of an axis (the open-loop runs of paper §4).

The steady state of the motor equations with the LuGre static curve (the torque–velocity map of
paper Fig. 8), solved for the forward motor's duty d at axis rate ω:

    N K/R ((1−p) d V − 2 K N ω) = Tc + (Ts−Tc) exp(−(ω/ωs)^δ) + σ2 ω + 2 cm N² ω

The counter motor is driven at p·d (the twin-motor preload law, §3.3) and is back-driven, so
both motors' back-EMF brakes (the ``2 K N ω`` term); ``cm`` is each motor's bearing drag.
Physics, so it lives in ``plant/``; the host's open-loop command uses it with the counter
fraction the firmware actually runs (one source: the scenario's, else the parameter file's).
"""

from __future__ import annotations

import math

from bus.units import ARCSEC_PER_RAD
from plant.params import AxisParameters

__all__ = ["open_loop_duty"]


def open_loop_duty(rate_arcsec_s: float, axis_params: AxisParameters, counter_fraction: float | None = None) -> float:
    """Duty that holds ``rate_arcsec_s`` in steady state by the model's duty–speed map.

    Parameters
    ----------
    rate_arcsec_s : float
        Target axis rate magnitude [arcsec/s].
    axis_params : plant.params.AxisParameters
        The axis (motor, gear, drive, active friction set).
    counter_fraction : float, optional
        p of the drive law; default the parameter file's ``drive.counter_fraction``. Pass the
        value the firmware runs when a scenario overrides it.

    Returns
    -------
    float
        Forward-motor duty (0..1, clipped).
    """
    m, g, fr = axis_params.motor, axis_params.gear, axis_params.friction
    fs = getattr(fr, fr.preload)
    p = axis_params.drive.counter_fraction if counter_fraction is None else counter_fraction
    w = abs(rate_arcsec_s) / ARCSEC_PER_RAD
    t_fric = fs.tc_nm + (fs.ts_nm - fs.tc_nm) * math.exp(-((w / fs.omega_s_rad_s) ** fr.delta)) + fs.sigma2_nm_s_rad * w
    n, k, r = g.ratio, m.torque_constant_nm_a, m.resistance_ohm
    t_fric += 2 * m.viscous_nm_s_rad * n * n * w  # motor bearing drag of both motors, reflected
    v = (t_fric * r / (n * k) + 2 * k * n * w) / (1.0 - p)
    return max(0.0, min(1.0, v / m.supply_v))
