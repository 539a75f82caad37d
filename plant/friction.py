"""LuGre friction on the telescope axis (paper §4, eqs. 3–5; Canudas de Wit et al. 1995).

All quantities are on the axis side: torque [N·m], angle [rad], rate [rad/s].

    T = σ0 z + σ1 dz/dt + σ2 ω                                  (eq. 3)
    dz/dt = ω − |ω| z / g(ω)                                    (eq. 4)
    σ0 g(ω) = Tc + (Ts − Tc) exp(−(|ω|/ωs)^δ)                  (eq. 5)

(The paper's eq. 4 prints a second derivative of θz on the left; it is the bristle rate dz/dt,
as in the LuGre model it cites.) With the optional direction-dependent fields, Tc and σ2 are chosen
by the sign of ω; Ts, ωs, δ, σ0 and σ1 are shared.

The integrator that advances z lives in :mod:`plant.axis` (inlined for speed); the functions here
are the reference definitions used by tests, calibration and documentation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from plant.effects import AsymmetricFriction, Presliding
from plant.params import FrictionParameters

__all__ = ["LuGre", "lugre_from_parameters", "static_friction_nm", "stribeck_nm"]


@dataclass(frozen=True)
class LuGre:
    """Resolved LuGre parameters for one axis (direction-dependent Tc, σ2 allowed).

    Attributes
    ----------
    sigma0_nm_rad : float
        Bristle stiffness σ0 [N·m/rad].
    sigma1_nm_s_rad : float
        Bristle damping σ1 [N·m·s/rad].
    tc_pos_nm, tc_neg_nm : float
        Coulomb level for ω >= 0 and ω < 0 (magnitudes) [N·m] (paper Table 2 Tc).
    ts_nm : float
        Stiction level Ts [N·m] (paper Table 2).
    omega_s_rad_s : float
        Stribeck velocity ωs [rad/s] (paper Table 2 vs).
    delta : float
        Stribeck exponent δ (assumed 2).
    sigma2_pos_nm_s_rad, sigma2_neg_nm_s_rad : float
        Viscous coefficient for ω >= 0 and ω < 0 [N·m·s/rad] (paper Table 2 σ2).
    """

    sigma0_nm_rad: float
    sigma1_nm_s_rad: float
    tc_pos_nm: float
    tc_neg_nm: float
    ts_nm: float
    omega_s_rad_s: float
    delta: float
    sigma2_pos_nm_s_rad: float
    sigma2_neg_nm_s_rad: float

    def stribeck_nm(self, omega_rad_s: float) -> float:
        """σ0·g(ω) [N·m] (eq. 5): the steady sliding friction level without the viscous part."""
        tc = self.tc_pos_nm if omega_rad_s >= 0.0 else self.tc_neg_nm
        return tc + (self.ts_nm - tc) * math.exp(-((abs(omega_rad_s) / self.omega_s_rad_s) ** self.delta))

    def g_rad(self, omega_rad_s: float) -> float:
        """g(ω) [rad]: the steady bristle deflection magnitude at rate ω."""
        return self.stribeck_nm(omega_rad_s) / self.sigma0_nm_rad

    def sigma2(self, omega_rad_s: float) -> float:
        """Viscous coefficient for the sign of ω [N·m·s/rad]."""
        return self.sigma2_pos_nm_s_rad if omega_rad_s >= 0.0 else self.sigma2_neg_nm_s_rad

    def static_nm(self, omega_rad_s: float) -> float:
        """Steady-state friction torque at constant ω ≠ 0 [N·m]: sign(ω)σ0 g(ω) + σ2 ω."""
        if omega_rad_s == 0.0:
            return 0.0
        s = 1.0 if omega_rad_s > 0.0 else -1.0
        return s * self.stribeck_nm(omega_rad_s) + self.sigma2(omega_rad_s) * omega_rad_s

    def z_rate(self, z_rad: float, omega_rad_s: float) -> float:
        """dz/dt [rad/s] (eq. 4)."""
        if omega_rad_s == 0.0:
            return 0.0
        return omega_rad_s - abs(omega_rad_s) * z_rad / self.g_rad(omega_rad_s)

    def torque_nm(self, z_rad: float, omega_rad_s: float) -> float:
        """Friction torque [N·m] (eq. 3) for bristle state z and rate ω."""
        return (
            self.sigma0_nm_rad * z_rad
            + self.sigma1_nm_s_rad * self.z_rate(z_rad, omega_rad_s)
            + self.sigma2(omega_rad_s) * omega_rad_s
        )


def lugre_from_parameters(friction: FrictionParameters, effects=()) -> LuGre:
    """Resolve the active Table 2 set, the asymmetric fields and mapped effects into a :class:`LuGre`.

    Parameters
    ----------
    friction : FrictionParameters
    effects : iterable of plant.effects.Effect, optional
        ``asymmetric_friction`` replaces Tc and σ2 per direction (``coulomb_pos_nm``…,
        ``viscous_pos_nm_s_rad``…); ``presliding`` replaces σ0 and σ1. Others are ignored here.

    Returns
    -------
    LuGre
    """
    s = friction.active
    tc_pos = friction.tc_pos_nm if friction.tc_pos_nm is not None else s.tc_nm
    tc_neg = friction.tc_neg_nm if friction.tc_neg_nm is not None else s.tc_nm
    s2_pos = friction.sigma2_pos_nm_s_rad if friction.sigma2_pos_nm_s_rad is not None else s.sigma2_nm_s_rad
    s2_neg = friction.sigma2_neg_nm_s_rad if friction.sigma2_neg_nm_s_rad is not None else s.sigma2_nm_s_rad
    sigma0, sigma1 = friction.sigma0_nm_rad, friction.sigma1_nm_s_rad
    for e in effects:
        kind = getattr(e, "kind", "")
        if kind == AsymmetricFriction.kind:
            tc_pos, tc_neg = float(e.coulomb_pos_nm), float(e.coulomb_neg_nm)
            s2_pos, s2_neg = float(e.viscous_pos_nm_s_rad), float(e.viscous_neg_nm_s_rad)
        elif kind == Presliding.kind:
            sigma0, sigma1 = float(e.sigma0_nm_rad), float(e.sigma1_nm_s_rad)
    return LuGre(
        sigma0_nm_rad=sigma0,
        sigma1_nm_s_rad=sigma1,
        tc_pos_nm=tc_pos,
        tc_neg_nm=tc_neg,
        ts_nm=s.ts_nm,
        omega_s_rad_s=s.omega_s_rad_s,
        delta=friction.delta,
        sigma2_pos_nm_s_rad=s2_pos,
        sigma2_neg_nm_s_rad=s2_neg,
    )


def stribeck_nm(omega_rad_s: float, tc_nm: float, ts_nm: float, omega_s_rad_s: float, delta: float) -> float:
    """Tc + (Ts − Tc) exp(−(|ω|/ωs)^δ) [N·m] (paper eq. 5)."""
    return tc_nm + (ts_nm - tc_nm) * math.exp(-((abs(omega_rad_s) / omega_s_rad_s) ** delta))


def static_friction_nm(omega_rad_s: float, lugre: LuGre) -> float:
    """Steady-state torque–velocity map (the paper's Fig. 8 curve) [N·m]; see :meth:`LuGre.static_nm`."""
    return lugre.static_nm(omega_rad_s)
