"""Named plant effects beyond the baseline model, shared by the emulator and the calibration loop.

Each effect is a small object with a ``kind`` (one of :data:`EFFECT_KINDS`), its parameters as
attributes (SI units, the unit in the name) and

* ``torque_nm(theta_rad, omega_rad_s, t_s) -> float``: the extra **load** torque [N·m] at axis
  angle ``theta_rad`` [rad], axis rate ``omega_rad_s`` [rad/s] and simulated time ``t_s`` [s].
  Positive opposes positive drive, i.e. the plant's equation of motion is
  ``J dω/dt = T_drive − T_baseline_friction − Σ effect.torque_nm(θ, ω, t)``.
* ``to_spec() -> dict``: ``{"kind": ..., **params}``, the form stored under
  ``axes.<axis>.effects`` in a plant parameter file; :func:`build_effect` is its inverse.

**Linear drives** (e.g. the EMPS ball-screw benchmark, which the calibration loop also handles):
the same classes and functions are used with positions in metres, velocities in m/s and forces in
newtons. The attribute names keep their rotary spelling (``period_rad`` holds metres,
``amplitude_nm`` holds newtons); the calibration report translates them to ``period_m`` /
``amplitude_n``. Nothing in this module depends on the unit system.

How each kind enters the plant (``additive`` says whether ``torque_nm`` is the whole story):

=====================  ==========  ===========================================================
kind                   additive    meaning
=====================  ==========  ===========================================================
asymmetric_friction    no (*)      direction-dependent viscous and Coulomb friction. In the
                                   plant it *replaces* the symmetric viscous (σ2) and Coulomb
                                   (Tc) parameters of the LuGre model for each sign of ω.
                                   ``torque_nm`` returns the full direction-dependent
                                   viscous + Coulomb torque (static map; 0 at ω = 0).
position_periodic      yes         ``A sin(2π θ/P + φ)``: gear or motor-revolution ripple.
gravity_imbalance      yes         ``A sin(θ + φ)``: once-per-axis-revolution imbalance.
presliding             no          the dynamic part of LuGre (σ0 bristle stiffness, σ1 bristle
                                   damping). It needs the bristle state, so it is meaningful only
                                   inside the plant's LuGre integrator; ``torque_nm`` returns 0.0.
backlash               no          a dead zone of ``width_rad`` in the gear train; maps onto the
                                   plant's gear backlash. ``torque_nm`` returns 0.0.
time_periodic          yes         ``A sin(2π f t + φ)``: a disturbance at a fixed frequency
                                   (e.g. a cooling fan, mains pick-up, an amplifier ripple).
=====================  ==========  ===========================================================

(*) ``torque_nm`` of ``asymmetric_friction`` is usable directly in a rigid-body simulation that has
no other viscous/Coulomb term; the full plant uses its parameters inside LuGre instead.

Phase of ``position_periodic``: ``phase_reference = "record"`` (default) means the phase is
relative to the start of the position record and must be refitted for every record (EMPS: the
motor-revolution ripple's phase differs between its two records because the position origin is
not tied to the motor's index). ``phase_reference = "index"`` means θ is measured from an encoder
index mark and the phase may be reused across runs.

Pure Python (``math`` only); no wall clock, no state except ``presliding``/``backlash``
parameters, which are only carried.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

__all__ = [
    "EFFECT_KINDS",
    "Effect",
    "AsymmetricFriction",
    "PositionPeriodic",
    "GravityImbalance",
    "Presliding",
    "Backlash",
    "TimePeriodic",
    "build_effect",
    "total_additive_torque_nm",
]


def _finite(kind: str, name: str, value: Any) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"effect {kind!r}: parameter {name!r} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"effect {kind!r}: parameter {name!r} must be finite, got {value!r}")
    return v


class Effect:
    """Base class: a named effect with float parameters.

    Subclasses set ``kind`` (str), ``PARAMS`` (required float parameter names),
    ``OPTIONAL`` (name -> default for optional parameters, floats or strings) and ``additive``.
    """

    kind: ClassVar[str] = ""
    PARAMS: ClassVar[tuple[str, ...]] = ()
    OPTIONAL: ClassVar[dict[str, Any]] = {}
    POSITIVE: ClassVar[tuple[str, ...]] = ()  # parameters that must be > 0
    NONNEGATIVE: ClassVar[tuple[str, ...]] = ()  # parameters that must be >= 0
    additive: ClassVar[bool] = True

    def __init__(self, **params: Any) -> None:
        valid = set(self.PARAMS) | set(self.OPTIONAL)
        unknown = sorted(set(params) - valid)
        if unknown:
            raise ValueError(
                f"effect {self.kind!r}: unknown parameter(s) {unknown}; valid: {sorted(valid)}"
            )
        missing = [p for p in self.PARAMS if p not in params]
        if missing:
            raise ValueError(
                f"effect {self.kind!r}: missing parameter(s) {missing}; required: {list(self.PARAMS)}"
            )
        for name in self.PARAMS:
            v = _finite(self.kind, name, params[name])
            if name in self.POSITIVE and not v > 0.0:
                raise ValueError(f"effect {self.kind!r}: {name!r} must be > 0, got {v}")
            if name in self.NONNEGATIVE and v < 0.0:
                raise ValueError(f"effect {self.kind!r}: {name!r} must be >= 0, got {v}")
            setattr(self, name, v)
        for name, default in self.OPTIONAL.items():
            setattr(self, name, params.get(name, default))
        self._validate()

    def _validate(self) -> None:  # hook for subclasses
        return None

    def params(self) -> dict[str, Any]:
        """Return the parameters as a plain dict (SI; see module docstring for linear drives)."""
        out: dict[str, Any] = {p: getattr(self, p) for p in self.PARAMS}
        for p, default in self.OPTIONAL.items():
            v = getattr(self, p)
            if v != default:
                out[p] = v
        return out

    def to_spec(self) -> dict[str, Any]:
        """Return ``{"kind": kind, **params}``, the inverse of :func:`build_effect`."""
        return {"kind": self.kind, **self.params()}

    def torque_nm(self, theta_rad: float, omega_rad_s: float, t_s: float) -> float:
        """Extra load torque [N·m] (positive opposes positive drive); see the module docstring."""
        raise NotImplementedError

    def __repr__(self) -> str:
        inner = ", ".join(f"{k}={v!r}" for k, v in self.params().items())
        return f"{type(self).__name__}({inner})"

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Effect) and self.to_spec() == other.to_spec()


class AsymmetricFriction(Effect):
    """Direction-dependent viscous and Coulomb friction.

    Parameters
    ----------
    viscous_pos_nm_s_rad, viscous_neg_nm_s_rad : float
        Viscous coefficient for ω > 0 and ω < 0 [N·m·s/rad] (linear drive: N·s/m).
    coulomb_pos_nm, coulomb_neg_nm : float
        Coulomb level for ω > 0 and ω < 0 [N·m] (linear: N), both given as magnitudes >= 0.

    Notes
    -----
    ``torque_nm`` = ``viscous_pos·ω + coulomb_pos`` for ω > 0, ``viscous_neg·ω − coulomb_neg``
    for ω < 0, 0 at ω = 0. In the plant these replace the symmetric σ2 and Tc of the LuGre model.
    """

    kind = "asymmetric_friction"
    PARAMS = ("viscous_pos_nm_s_rad", "viscous_neg_nm_s_rad", "coulomb_pos_nm", "coulomb_neg_nm")
    NONNEGATIVE = PARAMS
    additive = False

    def torque_nm(self, theta_rad: float, omega_rad_s: float, t_s: float) -> float:
        if omega_rad_s > 0.0:
            return self.viscous_pos_nm_s_rad * omega_rad_s + self.coulomb_pos_nm
        if omega_rad_s < 0.0:
            return self.viscous_neg_nm_s_rad * omega_rad_s - self.coulomb_neg_nm
        return 0.0


class PositionPeriodic(Effect):
    """Position-periodic load torque ``A sin(2π θ/P + φ)`` (gear or motor-revolution ripple).

    Parameters
    ----------
    period_rad : float
        Period P in axis angle [rad] (linear drive: m), > 0.
    amplitude_nm : float
        Amplitude A [N·m] (linear: N), >= 0.
    phase_rad : float
        Phase φ [rad] relative to θ = 0 of the record (``phase_reference="record"``, refitted per
        record) or to the encoder index (``phase_reference="index"``).
    phase_reference : {"record", "index"}, optional
    """

    kind = "position_periodic"
    PARAMS = ("period_rad", "amplitude_nm", "phase_rad")
    OPTIONAL = {"phase_reference": "record"}
    POSITIVE = ("period_rad",)
    NONNEGATIVE = ("amplitude_nm",)

    def _validate(self) -> None:
        if self.phase_reference not in ("record", "index"):
            raise ValueError(
                f"effect 'position_periodic': phase_reference must be 'record' or 'index', "
                f"got {self.phase_reference!r}"
            )

    def torque_nm(self, theta_rad: float, omega_rad_s: float, t_s: float) -> float:
        return self.amplitude_nm * math.sin(2.0 * math.pi * theta_rad / self.period_rad + self.phase_rad)


class GravityImbalance(Effect):
    """Once-per-axis-revolution imbalance torque ``A sin(θ + φ)``.

    Parameters
    ----------
    amplitude_nm : float
        A [N·m], >= 0.
    phase_rad : float
        φ [rad].
    """

    kind = "gravity_imbalance"
    PARAMS = ("amplitude_nm", "phase_rad")
    NONNEGATIVE = ("amplitude_nm",)

    def torque_nm(self, theta_rad: float, omega_rad_s: float, t_s: float) -> float:
        return self.amplitude_nm * math.sin(theta_rad + self.phase_rad)


class Presliding(Effect):
    """Pre-sliding (bristle) dynamics: the dynamic part of LuGre (paper §4, eqs. 3–5).

    Parameters
    ----------
    sigma0_nm_rad : float
        Bristle stiffness σ0 [N·m/rad] (linear: N/m), > 0.
    sigma1_nm_s_rad : float
        Bristle damping σ1 [N·m·s/rad] (linear: N·s/m), >= 0.

    Notes
    -----
    Stateful: the friction depends on the bristle deflection z, integrated by the plant's LuGre
    model with these σ0, σ1. ``torque_nm`` therefore returns 0.0 (``additive = False``); the plant
    maps the parameters onto its LuGre σ0/σ1.
    """

    kind = "presliding"
    PARAMS = ("sigma0_nm_rad", "sigma1_nm_s_rad")
    POSITIVE = ("sigma0_nm_rad",)
    NONNEGATIVE = ("sigma1_nm_s_rad",)
    additive = False

    def torque_nm(self, theta_rad: float, omega_rad_s: float, t_s: float) -> float:
        return 0.0


class Backlash(Effect):
    """Backlash (dead zone) of total width ``width_rad`` in the drive train.

    Parameters
    ----------
    width_rad : float
        Total play [rad at the axis] (linear: m), >= 0.

    Notes
    -----
    Stateful (which side of the gap is engaged); maps onto the plant's gear backlash.
    ``torque_nm`` returns 0.0 (``additive = False``).
    """

    kind = "backlash"
    PARAMS = ("width_rad",)
    NONNEGATIVE = ("width_rad",)
    additive = False

    def torque_nm(self, theta_rad: float, omega_rad_s: float, t_s: float) -> float:
        return 0.0


class TimePeriodic(Effect):
    """Time-periodic disturbance torque ``A sin(2π f t + φ)``.

    Parameters
    ----------
    frequency_hz : float
        f [Hz], > 0.
    amplitude_nm : float
        A [N·m] (linear: N), >= 0.
    phase_rad : float
        φ [rad] at t = 0 of the run (simulated time).
    """

    kind = "time_periodic"
    PARAMS = ("frequency_hz", "amplitude_nm", "phase_rad")
    POSITIVE = ("frequency_hz",)
    NONNEGATIVE = ("amplitude_nm",)

    def torque_nm(self, theta_rad: float, omega_rad_s: float, t_s: float) -> float:
        return self.amplitude_nm * math.sin(2.0 * math.pi * self.frequency_hz * t_s + self.phase_rad)


#: Registry: kind name -> class.
EFFECT_KINDS: dict[str, type[Effect]] = {
    cls.kind: cls
    for cls in (AsymmetricFriction, PositionPeriodic, GravityImbalance, Presliding, Backlash, TimePeriodic)
}


def build_effect(spec: dict[str, Any]) -> Effect:
    """Build an effect from ``{"kind": ..., **params}``.

    Parameters
    ----------
    spec : dict
        ``kind`` plus that kind's parameters (SI, names as in the classes).

    Returns
    -------
    Effect

    Raises
    ------
    ValueError
        Unknown kind (lists the valid kinds), unknown/missing parameter (names the kind and its valid
        parameters) or a non-finite/out-of-range value.
    """
    if not isinstance(spec, dict):
        raise ValueError(f"effect spec must be a mapping with a 'kind' key, got {type(spec).__name__}")
    if "kind" not in spec:
        raise ValueError(f"effect spec has no 'kind'; valid kinds: {sorted(EFFECT_KINDS)}")
    kind = spec["kind"]
    cls = EFFECT_KINDS.get(kind)
    if cls is None:
        raise ValueError(f"unknown effect kind {kind!r}; valid kinds: {sorted(EFFECT_KINDS)}")
    params = {k: v for k, v in spec.items() if k != "kind"}
    return cls(**params)


def total_additive_torque_nm(effects: list[Effect], theta_rad: float, omega_rad_s: float, t_s: float) -> float:
    """Sum ``torque_nm`` over the *additive* effects (position/time periodic, gravity imbalance).

    Non-additive effects (asymmetric friction, presliding, backlash) are skipped: the plant applies
    them through its friction and gear models.
    """
    total = 0.0
    for e in effects:
        if e.additive:
            total += e.torque_nm(theta_rad, omega_rad_s, t_s)
    return total
