"""Control law of the axis controller: incremental PI (paper §4) and twin-motor drive laws (§3.3).

Pure functions/classes with no hardware or time dependence, so the firmware
(:mod:`boards.axis_controller`) and the tests use exactly the same arithmetic.

Units: error E in arcsec/s of axis rate; control effort U as a signed duty fraction
(−u_max .. +u_max, +1 = 100 % duty on the positive-direction motor A); Kp in duty per (″/s);
Ki in duty per (″/s) per 5 ms tick.
"""

from __future__ import annotations

from typing import Callable, Dict, Final, Tuple

__all__ = ["IncrementalPI", "DRIVE_LAWS", "drive_proportional", "drive_constant_counter",
           "register_drive_law"]


class IncrementalPI:
    """Velocity-form ("incremental") PI of the paper §4 with the effort clamped in place.

    ``E_k = ω_sp − ω_k``; ``dU_k = Kp (E_k − E_{k−1}) + Ki E_k``;
    ``U_k = clip(U_{k−1} + dU_k, −u_max, +u_max)``.

    Anti-windup: the only state carried between ticks is ``U_{k−1}`` (already clamped) and
    ``E_{k−1}``; there is no separate integrator that could keep growing while the output is
    saturated. So clamping U itself *is* the anti-windup (the paper: "upper and lower limits are
    imposed on the U_k before loading the PWM duty cycle register"), and U leaves a limit on the
    first tick whose increment points back inside (e.g. the tick where the error changes sign,
    since then both Kp ΔE and Ki E_k have the inward sign).

    Bumpless transfer: a change of setpoint (preset speed) touches neither U nor E_{k−1}; the
    tick after the switch applies the ordinary increment ``Kp (E_k − E_{k−1}) + Ki E_k`` to the
    previous U. U is therefore continuous across a mode change apart from that one increment,
    whose proportional part is ``Kp·Δω_sp`` (the set-point step, not the full Kp·E_k a
    positional PI with a freshly reset integrator would jump by).

    Parameters
    ----------
    kp : float
        Proportional gain, duty per (arcsec/s).
    ki : float
        Integral gain per tick, duty per (arcsec/s) per tick.
    u_max : float
        Effort limit, duty fraction (0 < u_max ≤ 1).
    """

    def __init__(self, kp: float, ki: float, u_max: float = 1.0) -> None:
        if not 0.0 < u_max <= 1.0:
            raise ValueError(f"u_max must be in (0, 1], got {u_max}")
        self.kp = float(kp)
        self.ki = float(ki)
        self.u_max = float(u_max)
        self.u = 0.0
        self.e_prev = 0.0
        self.saturated = False

    def update(self, error: float) -> float:
        """One tick: apply the increment for ``error`` (″/s); returns the clamped U."""
        du = self.kp * (error - self.e_prev) + self.ki * error
        u = self.u + du
        if u > self.u_max:
            u, self.saturated = self.u_max, True
        elif u < -self.u_max:
            u, self.saturated = -self.u_max, True
        else:
            self.saturated = False
        self.u = u
        self.e_prev = error
        return u

    def force(self, u: float, e_prev: float = 0.0) -> None:
        """Load U and E_{k−1} directly (open loop, limit stop); U is clamped."""
        self.u = max(-self.u_max, min(self.u_max, float(u)))
        self.e_prev = float(e_prev)
        self.saturated = abs(self.u) >= self.u_max

    def reset(self) -> None:
        """U = 0, E_{k−1} = 0."""
        self.u = 0.0
        self.e_prev = 0.0
        self.saturated = False


DriveLaw = Callable[[float, float], Tuple[float, float]]


def drive_proportional(u: float, counter_fraction: float) -> Tuple[float, float]:
    """The paper's twin-motor law (§3.3): forward motor |U|, reverse motor p·|U|.

    Parameters
    ----------
    u : float
        Control effort, signed duty fraction (+ drives motor A, the positive-direction motor).
    counter_fraction : float
        p, 0.10-0.25 in the paper.

    Returns
    -------
    (duty_a, duty_b) : tuple of float
        Each in 0..1. Net effort by superposition: (1 − p)·U.
    """
    a = abs(u)
    if u >= 0.0:
        return (a, counter_fraction * a)
    return (counter_fraction * a, a)


def drive_constant_counter(u: float, counter_fraction: float) -> Tuple[float, float]:
    """Alternative law (not the paper's): the reverse motor gets a constant duty p.

    The forward motor gets min(1, |U| + p) so that the net effort is still ≈ U; the preload
    exists even at U = 0. Offered so the preload-law decision (see the plant documentation) can
    be tried without changing firmware code.
    """
    p = counter_fraction
    a = min(1.0, abs(u) + p)
    if u >= 0.0:
        return (a, p)
    return (p, a)


DRIVE_LAWS: Final[Dict[str, DriveLaw]] = {
    "proportional": drive_proportional,
    "constant_counter": drive_constant_counter,
}


def register_drive_law(name: str, law: DriveLaw) -> None:
    """Add a drive law ``law(u, counter_fraction) -> (duty_a, duty_b)`` to the table."""
    DRIVE_LAWS[name] = law
