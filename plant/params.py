"""Plant parameter file: loading, dotted overrides, typed access and writing.

The file (``plant/parameters.yaml`` by default) is a tree whose leaves are
``{value, unit, source}``; ``axes.<axis>.effects`` is a plain list of effect specs
(``{kind, **params}``, see :mod:`plant.effects`). Values are SI unless the key names another unit
(``backlash_motor_deg``, ``halfstep_angle_deg``, ``max_substep_us``, ``incremental_error_arcsec``).

Typed objects are frozen dataclasses whose field names are the YAML keys, so
``params.axes["ra"].friction.sigma0_nm_rad`` reads ``axes.ra.friction.sigma0_nm_rad``. Derived
quantities (``GearParameters.backlash_rad``, ``FrictionParameters.active``…) are properties.
:func:`dump_parameters` writes the typed values back into the file format, keeping units and
sources, so ``dataclasses.replace`` edits survive a round trip.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import yaml

__all__ = [
    "ParameterError",
    "DEFAULT_PATH",
    "MotorParameters",
    "GearParameters",
    "DriveParameters",
    "FrictionSet",
    "FrictionParameters",
    "EncoderParameters",
    "AxisParameters",
    "FocusParameters",
    "PlantParameters",
    "load_parameters",
    "dump_parameters",
]

#: The parameter file shipped with the package.
DEFAULT_PATH = Path(__file__).with_name("parameters.yaml")

PRELOAD_SETS = ("low", "high")
PRELOAD_LAWS = ("proportional",)
DRIVE_MODELS = ("twin_train", "rigid")
AXIS_NAMES = ("ra", "dec")


class ParameterError(ValueError):
    """A parameter file or override is invalid (names the path and, where useful, the valid keys)."""


# --------------------------------------------------------------------------- typed objects


@dataclass(frozen=True)
class MotorParameters:
    """One brushed DC torque motor (Kollmorgen QT-3124) with its low-side MOSFET drive.

    Attributes
    ----------
    resistance_ohm : float
        Armature resistance R [Ω] (assumed, see the YAML source).
    inductance_h : float
        Armature inductance L [H] (assumed).
    torque_constant_nm_a : float
        Kt = Ke [N·m/A], [V·s/rad] (assumed).
    rotor_inertia_kg_m2 : float
        Rotor + first pinion inertia at the motor shaft [kg·m²] (assumed).
    viscous_nm_s_rad : float
        Motor-shaft viscous drag [N·m·s/rad] (assumed).
    rated_current_a : float
        Continuous rating, 6 A (paper §3.2); not enforced, only reported.
    supply_v : float
        Supply voltage, 24 V (paper §3.2, §3.3).
    shunt_ohm : float
        Current shunt, 0.1 Ω (paper §3.3).
    """

    resistance_ohm: float
    inductance_h: float
    torque_constant_nm_a: float
    rotor_inertia_kg_m2: float
    viscous_nm_s_rad: float
    rated_current_a: float
    supply_v: float
    shunt_ohm: float


@dataclass(frozen=True)
class GearParameters:
    """One of the two identical gear trains of an axis (paper §2.2, Table 1).

    Attributes
    ----------
    ratio : float
        Motor revolutions per axis revolution, 360.489 (paper §2.2).
    backlash_motor_deg : float
        Total play of one train measured at the motor shaft [deg] (paper §2.2: ≈21°).
    stiffness_nm_rad : float
        Stiffness of both trains together at the axis [N·m/rad] (paper Table 1).
    damping_ratio : float
        Mesh damping as a fraction of critical for the lock-rotor mode (assumed).
    """

    ratio: float
    backlash_motor_deg: float
    stiffness_nm_rad: float
    damping_ratio: float

    @property
    def backlash_rad(self) -> float:
        """Total dead-zone width of one train at the axis [rad] = backlash_motor_deg / ratio."""
        return math.radians(self.backlash_motor_deg) / self.ratio

    @property
    def train_stiffness_nm_rad(self) -> float:
        """Stiffness of one train at the axis [N·m/rad] (half the Table 1 value)."""
        return 0.5 * self.stiffness_nm_rad


@dataclass(frozen=True)
class DriveParameters:
    """The twin-motor preload law carried for the firmware (paper §3.3).

    Attributes
    ----------
    preload_law : str
        ``"proportional"``: counter duty = ``counter_fraction`` × |U|.
    counter_fraction : float
        p, 0.10–0.25 (paper §3.3; Table 1 "Counter torque (25%)").
    """

    preload_law: str
    counter_fraction: float


@dataclass(frozen=True)
class FrictionSet:
    """One Table 2 LuGre set (paper §4): σ2 [N·m·s/rad], Tc, Ts [N·m], ωs [rad/s]."""

    sigma2_nm_s_rad: float
    tc_nm: float
    ts_nm: float
    omega_s_rad_s: float


@dataclass(frozen=True)
class FrictionParameters:
    """LuGre friction on the axis (paper eqs. 3–5, Table 2).

    Attributes
    ----------
    preload : str
        ``"low"`` or ``"high"``: which Table 2 set is active.
    sigma0_nm_rad, sigma1_nm_s_rad : float
        Bristle stiffness [N·m/rad] and damping [N·m·s/rad] (assumed; not in the paper).
    delta : float
        Stribeck exponent δ (assumed 2).
    low, high : FrictionSet
        The two Table 2 sets.
    tc_pos_nm, tc_neg_nm, sigma2_pos_nm_s_rad, sigma2_neg_nm_s_rad : float or None
        Optional direction-dependent Coulomb level (magnitude) and viscous coefficient; ``None``
        uses the active set's symmetric value.
    """

    preload: str
    sigma0_nm_rad: float
    sigma1_nm_s_rad: float
    delta: float
    low: FrictionSet
    high: FrictionSet
    tc_pos_nm: float | None = None
    tc_neg_nm: float | None = None
    sigma2_pos_nm_s_rad: float | None = None
    sigma2_neg_nm_s_rad: float | None = None

    @property
    def active(self) -> FrictionSet:
        """The Table 2 set selected by ``preload``."""
        return self.low if self.preload == "low" else self.high


@dataclass(frozen=True)
class EncoderParameters:
    """Axis encoders (paper §2.2, §3.2).

    Attributes
    ----------
    incremental_counts_per_rev : int
        Counts per encoder-shaft revolution, 4 608 000.
    roller_ratio : float
        Encoder revolutions per axis revolution, 24.5 (friction roller 735:30).
    incremental_error_arcsec : float
        Amplitude of a once-per-encoder-revolution position error [arcsec] (assumed 0).
    absolute_bits : int
        Absolute encoder word width, 29.
    """

    incremental_counts_per_rev: int
    roller_ratio: float
    incremental_error_arcsec: float
    absolute_bits: int

    @property
    def counts_per_axis_rev(self) -> float:
        """Incremental counts per axis revolution (1.12896e8)."""
        return self.incremental_counts_per_rev * self.roller_ratio

    @property
    def arcsec_per_count(self) -> float:
        """Incremental resolution at the axis [arcsec/count] (0.01148)."""
        return 1_296_000.0 / self.counts_per_axis_rev


@dataclass(frozen=True)
class AxisParameters:
    """Everything one :class:`plant.axis.AxisPlant` needs.

    Attributes
    ----------
    name : str
        ``"ra"`` or ``"dec"``.
    inertia_kg_m2 : float
        Axis load inertia [kg·m²] (paper §4 / Table 1), excluding the motor rotors.
    max_substep_us : int
        Longest integrator substep [µs].
    drive_model : str
        ``"twin_train"`` or ``"rigid"``.
    motor, gear, drive, friction, encoders
        Sub-sections.
    effects : tuple of dict
        Effect specs ``{kind, **params}`` (built by :func:`plant.effects.build_effect`).
    gear_disturbance : dict
        Gear-train torque lines ``{line: {amplitude_nm, phase…_rad}}``, validated by
        :func:`plant.gear_train_disturbance.parse_section` (empty when the file has no section).
    perfect : bool
        Copy of the file's top-level ``perfect`` switch.
    """

    name: str
    inertia_kg_m2: float
    max_substep_us: int
    drive_model: str
    motor: MotorParameters
    gear: GearParameters
    drive: DriveParameters
    friction: FrictionParameters
    encoders: EncoderParameters
    effects: tuple = ()
    perfect: bool = False
    gear_disturbance: dict = field(default_factory=dict)

    @property
    def reflected_motor_inertia_kg_m2(self) -> float:
        """Inertia of both rotors seen at the axis, 2·Jm·N² [kg·m²]."""
        return 2.0 * self.motor.rotor_inertia_kg_m2 * self.gear.ratio ** 2


@dataclass(frozen=True)
class FocusParameters:
    """Focus mechanism (paper §3.2, §3.3); see :class:`plant.focus.FocusPlant`.

    Attributes
    ----------
    screw_lead_m : float
        Ball-screw travel per screw revolution [m] (5 mm).
    belt_ratio : float
        Motor revolutions per screw revolution (2).
    halfstep_angle_deg : float
        Motor angle per half-step [deg] (0.9).
    travel_m : float
        Half range of travel [m] (±5 mm).
    lvdt_center_v, lvdt_span_v : float
        LVDT output at 0 and its change at full travel [V] (assumed 2.5 V ± 2.5 V).
    adc_bits : int
        LVDT ADC resolution (10).
    motor_encoder_counts_per_rev : int
        Motor shaft encoder counts per motor revolution (assumed 2000).
    index_offset_m : float
        Position of the index pulse nearest 0 [m]; further ones every motor revolution.
    """

    screw_lead_m: float
    belt_ratio: float
    halfstep_angle_deg: float
    travel_m: float
    lvdt_center_v: float
    lvdt_span_v: float
    adc_bits: int
    motor_encoder_counts_per_rev: int
    index_offset_m: float

    @property
    def halfsteps_per_motor_rev(self) -> float:
        """400 half-steps per motor revolution at 0.9°."""
        return 360.0 / self.halfstep_angle_deg

    @property
    def metres_per_motor_rev(self) -> float:
        """2.5 mm of travel per motor revolution."""
        return self.screw_lead_m / self.belt_ratio

    @property
    def metres_per_halfstep(self) -> float:
        """6.25 µm per half-step (paper §3.2)."""
        return self.metres_per_motor_rev / self.halfsteps_per_motor_rev


@dataclass(frozen=True)
class PlantParameters:
    """The whole parameter file, typed.

    Attributes
    ----------
    perfect : bool
        The top-level switch (see :mod:`plant.axis` and docs/plant.md).
    axes : dict[str, AxisParameters]
        ``"ra"`` and ``"dec"``.
    focus : FocusParameters
    tree : dict
        The raw file tree (with overrides applied); units and sources for :func:`dump_parameters`.
    """

    perfect: bool
    axes: dict
    focus: FocusParameters
    tree: dict = field(repr=False, compare=False, default_factory=dict)

    @property
    def ra(self) -> AxisParameters:
        return self.axes["ra"]

    @property
    def dec(self) -> AxisParameters:
        return self.axes["dec"]


# --------------------------------------------------------------------------- tree helpers


def _is_leaf(node: Any) -> bool:
    return isinstance(node, dict) and "value" in node


def _keys(node: Any) -> list[str]:
    return sorted(node.keys()) if isinstance(node, dict) else []


def _set_path(tree: dict, path: str, value: Any) -> None:
    parts = path.split(".")
    node: Any = tree
    walked: list[str] = []
    for i, part in enumerate(parts):
        if not isinstance(node, dict) or _is_leaf(node):
            raise ParameterError(
                f"override {path!r}: {'.'.join(walked) or '<root>'} is a leaf, it has no key {part!r}"
            )
        if part not in node:
            raise ParameterError(
                f"override {path!r}: no key {part!r} under {'.'.join(walked) or '<root>'}; "
                f"valid keys: {_keys(node)}"
            )
        walked.append(part)
        if i == len(parts) - 1:
            target = node[part]
            if _is_leaf(target):
                target["value"] = value
            elif part == "effects":
                if not isinstance(value, (list, tuple)):
                    raise ParameterError(f"override {path!r}: effects must be a list of effect specs")
                node[part] = [dict(e) for e in value]
            else:
                raise ParameterError(
                    f"override {path!r} names a section, not a leaf; valid keys: {_keys(target)}"
                )
        else:
            node = node[part]


class _Reader:
    """Reads a section's leaves, checking that exactly the expected keys are present."""

    def __init__(self, node: Any, path: str) -> None:
        if not isinstance(node, dict) or _is_leaf(node):
            raise ParameterError(f"{path}: expected a section (mapping of keys)")
        self.node = node
        self.path = path
        self.used: set[str] = set()

    def _leaf(self, key: str) -> Any:
        if key not in self.node:
            raise ParameterError(f"{self.path}.{key}: missing; present keys: {_keys(self.node)}")
        self.used.add(key)
        leaf = self.node[key]
        if not _is_leaf(leaf):
            raise ParameterError(f"{self.path}.{key}: expected a leaf {{value, unit, source}}")
        return leaf["value"]

    def float(self, key: str, *, positive: bool = False, nonneg: bool = False, optional: bool = False):
        v = self._leaf(key)
        if v is None and optional:
            return None
        if isinstance(v, str):  # YAML 1.1 reads "3e6" as a string; CLI overrides arrive as text
            try:
                v = float(v)
            except ValueError:
                pass
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise ParameterError(f"{self.path}.{key}: expected a number, got {v!r}")
        v = float(v)
        if not math.isfinite(v):
            raise ParameterError(f"{self.path}.{key}: must be finite, got {v!r}")
        if positive and not v > 0.0:
            raise ParameterError(f"{self.path}.{key}: must be > 0, got {v!r}")
        if nonneg and v < 0.0:
            raise ParameterError(f"{self.path}.{key}: must be >= 0, got {v!r}")
        return v

    def int(self, key: str, *, positive: bool = True) -> int:
        v = self._leaf(key)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or v != int(v):
            raise ParameterError(f"{self.path}.{key}: expected an integer, got {v!r}")
        if positive and int(v) <= 0:
            raise ParameterError(f"{self.path}.{key}: must be > 0, got {v!r}")
        return int(v)

    def choice(self, key: str, valid: tuple[str, ...]) -> str:
        v = self._leaf(key)
        if v not in valid:
            raise ParameterError(f"{self.path}.{key}: {v!r} is not one of {list(valid)}")
        return str(v)

    def bool(self, key: str) -> bool:
        v = self._leaf(key)
        if not isinstance(v, bool):
            raise ParameterError(f"{self.path}.{key}: expected true/false, got {v!r}")
        return v

    def section(self, key: str) -> "_Reader":
        if key not in self.node:
            raise ParameterError(f"{self.path}.{key}: missing section; present keys: {_keys(self.node)}")
        self.used.add(key)
        return _Reader(self.node[key], f"{self.path}.{key}")

    def done(self) -> None:
        extra = sorted(set(self.node) - self.used)
        if extra:
            raise ParameterError(
                f"{self.path}: unknown key(s) {extra}; valid keys: {sorted(self.used)}"
            )


def _motor(r: _Reader) -> MotorParameters:
    m = MotorParameters(
        resistance_ohm=r.float("resistance_ohm", positive=True),
        inductance_h=r.float("inductance_h", positive=True),
        torque_constant_nm_a=r.float("torque_constant_nm_a", positive=True),
        rotor_inertia_kg_m2=r.float("rotor_inertia_kg_m2", positive=True),
        viscous_nm_s_rad=r.float("viscous_nm_s_rad", nonneg=True),
        rated_current_a=r.float("rated_current_a", positive=True),
        supply_v=r.float("supply_v", positive=True),
        shunt_ohm=r.float("shunt_ohm", positive=True),
    )
    r.done()
    return m


def _gear(r: _Reader) -> GearParameters:
    g = GearParameters(
        ratio=r.float("ratio", positive=True),
        backlash_motor_deg=r.float("backlash_motor_deg", nonneg=True),
        stiffness_nm_rad=r.float("stiffness_nm_rad", positive=True),
        damping_ratio=r.float("damping_ratio", nonneg=True),
    )
    r.done()
    return g


def _drive(r: _Reader) -> DriveParameters:
    d = DriveParameters(
        preload_law=r.choice("preload_law", PRELOAD_LAWS),
        counter_fraction=r.float("counter_fraction", nonneg=True),
    )
    if d.counter_fraction > 1.0:
        raise ParameterError(f"{r.path}.counter_fraction: must be <= 1, got {d.counter_fraction}")
    r.done()
    return d


def _fset(r: _Reader) -> FrictionSet:
    s = FrictionSet(
        sigma2_nm_s_rad=r.float("sigma2_nm_s_rad", nonneg=True),
        tc_nm=r.float("tc_nm", nonneg=True),
        ts_nm=r.float("ts_nm", nonneg=True),
        omega_s_rad_s=r.float("omega_s_rad_s", positive=True),
    )
    r.done()
    return s


def _friction(r: _Reader) -> FrictionParameters:
    f = FrictionParameters(
        preload=r.choice("preload", PRELOAD_SETS),
        sigma0_nm_rad=r.float("sigma0_nm_rad", positive=True),
        sigma1_nm_s_rad=r.float("sigma1_nm_s_rad", nonneg=True),
        delta=r.float("delta", positive=True),
        low=_fset(r.section("low")),
        high=_fset(r.section("high")),
        tc_pos_nm=r.float("tc_pos_nm", nonneg=True, optional=True),
        tc_neg_nm=r.float("tc_neg_nm", nonneg=True, optional=True),
        sigma2_pos_nm_s_rad=r.float("sigma2_pos_nm_s_rad", nonneg=True, optional=True),
        sigma2_neg_nm_s_rad=r.float("sigma2_neg_nm_s_rad", nonneg=True, optional=True),
    )
    r.done()
    return f


def _encoders(r: _Reader) -> EncoderParameters:
    e = EncoderParameters(
        incremental_counts_per_rev=r.int("incremental_counts_per_rev"),
        roller_ratio=r.float("roller_ratio", positive=True),
        incremental_error_arcsec=r.float("incremental_error_arcsec", nonneg=True),
        absolute_bits=r.int("absolute_bits"),
    )
    r.done()
    return e


def _effects(node: dict, path: str) -> tuple:
    if "effects" not in node:
        raise ParameterError(f"{path}.effects: missing (use [] for none)")
    effs = node["effects"]
    if effs is None:
        effs = []
    if not isinstance(effs, list):
        raise ParameterError(f"{path}.effects: expected a list of {{kind, params...}}")
    out = []
    for i, spec in enumerate(effs):
        if not isinstance(spec, dict) or "kind" not in spec:
            raise ParameterError(f"{path}.effects[{i}]: expected a mapping with a 'kind' key")
        try:  # validate now so a bad scenario fails at load time
            from plant.effects import build_effect

            build_effect(dict(spec))
        except ImportError:  # pragma: no cover - effects module is part of the package
            pass
        except ValueError as exc:
            raise ParameterError(f"{path}.effects[{i}]: {exc}") from None
        out.append(dict(spec))
    return tuple(out)


def _gear_disturbance(node: dict, path: str) -> dict:
    # issue 9 hook: the section's schema lives in plant/gear_train_disturbance.py
    from plant.gear_train_disturbance import parse_section

    try:
        return parse_section(node.get("gear_disturbance"), f"{path}.gear_disturbance")
    except ValueError as exc:
        raise ParameterError(str(exc)) from None


def _axis(node: Any, name: str, perfect: bool) -> AxisParameters:
    path = f"axes.{name}"
    r = _Reader(node, path)
    a = AxisParameters(
        name=name,
        inertia_kg_m2=r.float("inertia_kg_m2", positive=True),
        max_substep_us=r.int("max_substep_us"),
        drive_model=r.choice("drive_model", DRIVE_MODELS),
        motor=_motor(r.section("motor")),
        gear=_gear(r.section("gear")),
        drive=_drive(r.section("drive")),
        friction=_friction(r.section("friction")),
        encoders=_encoders(r.section("encoders")),
        effects=_effects(node, path),
        perfect=perfect,
        gear_disturbance=_gear_disturbance(node, path),
    )
    r.used.update(("effects", "gear_disturbance"))
    r.done()
    return a


def _focus(r: _Reader) -> FocusParameters:
    f = FocusParameters(
        screw_lead_m=r.float("screw_lead_m", positive=True),
        belt_ratio=r.float("belt_ratio", positive=True),
        halfstep_angle_deg=r.float("halfstep_angle_deg", positive=True),
        travel_m=r.float("travel_m", positive=True),
        lvdt_center_v=r.float("lvdt_center_v"),
        lvdt_span_v=r.float("lvdt_span_v", positive=True),
        adc_bits=r.int("adc_bits"),
        motor_encoder_counts_per_rev=r.int("motor_encoder_counts_per_rev"),
        index_offset_m=r.float("index_offset_m"),
    )
    r.done()
    return f


def parameters_from_tree(tree: dict) -> PlantParameters:
    """Build typed parameters from a parsed file tree (no overrides).

    Raises
    ------
    ParameterError
        Missing/unknown keys, wrong types or out-of-range values (message names the path).
    """
    root = _Reader(tree, "<root>")
    root.choice("schema", ("schmidt-fil/plant-parameters/1",))
    perfect = root.bool("perfect")
    axes_r = root.section("axes")
    axes = {}
    for name in AXIS_NAMES:
        if name not in axes_r.node:
            raise ParameterError(f"axes.{name}: missing; present keys: {_keys(axes_r.node)}")
        axes_r.used.add(name)
        axes[name] = _axis(axes_r.node[name], name, perfect)
    axes_r.done()
    focus = _focus(root.section("focus"))
    root.done()
    return PlantParameters(perfect=perfect, axes=axes, focus=focus, tree=tree)


def load_parameters(
    path: str | Path | None = None, overrides: Mapping[str, Any] | None = None
) -> PlantParameters:
    """Load a plant parameter file and apply dotted overrides.

    Parameters
    ----------
    path : str or Path, optional
        YAML file; default :data:`DEFAULT_PATH` (``plant/parameters.yaml``).
    overrides : mapping of str to value, optional
        ``{"axes.ra.friction.sigma0_nm_rad": 2e8, "axes.ra.friction.preload": "high",
        "perfect": True}``: each sets the ``value`` of that leaf (same unit as the file).
        ``"axes.<axis>.effects"`` takes a whole list of effect specs.

    Returns
    -------
    PlantParameters

    Raises
    ------
    ParameterError
        Unknown override path (names the path and the valid keys at the point it failed), a
        section given instead of a leaf, or an invalid file/value.
    FileNotFoundError
        ``path`` does not exist.
    """
    p = Path(path) if path is not None else DEFAULT_PATH
    with open(p, "r", encoding="utf-8") as fh:
        tree = yaml.safe_load(fh)
    if not isinstance(tree, dict):
        raise ParameterError(f"{p}: not a parameter tree")
    for key, value in (overrides or {}).items():
        _set_path(tree, key, value)
    return parameters_from_tree(tree)


def _value_of(params: PlantParameters, path: list[str]) -> Any:
    """Typed value for a leaf path (axes.ra.friction.low.tc_nm -> params.axes['ra'].friction.low.tc_nm)."""
    if path == ["perfect"]:
        return params.perfect
    obj: Any = params
    for part in path:
        if isinstance(obj, dict):
            obj = obj[part]
        elif part == "axes":
            obj = params.axes
        else:
            obj = getattr(obj, part)
    return obj


def _plain(v: Any) -> Any:
    if isinstance(v, float) and v == int(v) and abs(v) < 1e15 and False:
        return int(v)
    return v


def dump_parameters(params: PlantParameters, path: str | Path) -> None:
    """Write parameters in the file format (units and sources kept from ``params.tree``).

    Values come from the typed objects, so ``dataclasses.replace`` edits are written. Effects are
    written from ``AxisParameters.effects``.

    Parameters
    ----------
    params : PlantParameters
    path : str or Path
        Output YAML file (overwritten).
    """
    tree = copy.deepcopy(params.tree) if params.tree else copy.deepcopy(
        yaml.safe_load(DEFAULT_PATH.read_text(encoding="utf-8"))
    )

    def walk(node: Any, prefix: list[str]) -> None:
        for key, child in node.items():
            if _is_leaf(child):
                if prefix == [] and key == "schema":
                    continue
                v = _value_of(params, prefix + [key])
                child["value"] = _plain(v)
            elif key == "effects" and prefix[:1] == ["axes"]:
                node[key] = [dict(e) for e in _value_of(params, prefix + [key])]
            elif isinstance(child, dict):
                walk(child, prefix + [key])

    walk(tree, [])
    text = (
        "# schmidt-fil plant parameters (written by plant.params.dump_parameters).\n"
        "# Every leaf is {value, unit, source}; see plant/parameters.yaml and docs/plant.md.\n"
    ) + yaml.safe_dump(tree, sort_keys=False, allow_unicode=True, width=100)
    Path(path).write_text(text, encoding="utf-8")
