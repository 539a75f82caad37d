"""Plant parameter file: loading, dotted overrides, typed access and writing.

The file (``plant/parameters.yaml`` by default) is a tree whose leaves are
``{value, unit, source}``; ``axes.<axis>.effects`` is a plain list of effect specs
(``{kind, **params}``, see :mod:`plant.effects`). Values are SI unless the key names another unit
(``backlash_motor_deg``, ``halfstep_angle_deg``, ``max_substep_us``, ``incremental_error_arcsec``).

Typed objects are frozen (pydantic) dataclasses whose field names are the YAML keys, so
``params.axes["ra"].friction.sigma0_nm_rad`` reads ``axes.ra.friction.sigma0_nm_rad``. They are
the ONE schema of the file: each field is declared once with its type and bound, and
:func:`parameters_from_tree` validates the whole tree against them (an error names the dotted path
and what was expected, as :class:`ParameterError`, a :class:`bus.errors.ConfigurationError`).
A new parameter = one field in its class + its leaf (value, unit, source) in parameters.yaml; a
new section = one class + one field of the parent. Derived quantities
(``GearParameters.backlash_rad``, ``FrictionParameters.active``…) are properties.
:func:`dump_parameters` writes the typed values back into the file format, keeping units and
sources, so ``dataclasses.replace`` edits (validated again) survive a round trip.
"""

from __future__ import annotations

import copy
import math
from dataclasses import field
from pathlib import Path
from typing import Annotated, Any, Literal, Mapping

import yaml
from pydantic import AfterValidator, BeforeValidator, ConfigDict, Field, TypeAdapter, ValidationError
from pydantic.dataclasses import dataclass

from bus.errors import ConfigurationError
from bus.units import ARCSEC_PER_REV, check_counter_fraction

__all__ = [
    "ParameterError",
    "DEFAULT_PATH",
    "SCHEMA",
    "MotorParameters",
    "GearParameters",
    "DriveParameters",
    "FrictionSet",
    "FrictionParameters",
    "EncoderParameters",
    "TachometerParameters",
    "AuxEncoderParameters",
    "AxisParameters",
    "FocusParameters",
    "PlantParameters",
    "load_parameters",
    "dump_parameters",
    "parameters_from_tree",
]

#: The parameter file shipped with the package.
DEFAULT_PATH = Path(__file__).with_name("parameters.yaml")
#: The file format version (the ``schema`` leaf).
SCHEMA = "schmidt-fil/plant-parameters/1"
AXIS_NAMES = ("ra", "dec")


class ParameterError(ConfigurationError, ValueError):
    """A parameter file or override is invalid (names the path and, where useful, the valid keys).

    In the project's error tree (:class:`bus.errors.ConfigurationError`); also a ``ValueError``.
    """


# --------------------------------------------------------------------------- field types
# Every field of the file is declared once, in the typed classes below, with its constraint;
# the loader validates the whole tree against them (pydantic) and names the dotted path of the
# first error. A new parameter is one field in one class (+ its leaf in parameters.yaml).


def _number(v: Any) -> float:
    if isinstance(v, str):  # YAML 1.1 reads "3e6" as a string; CLI overrides arrive as text
        try:
            v = float(v)
        except ValueError:
            pass
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ValueError(f"expected a number, got {v!r}")
    if not math.isfinite(v):
        raise ValueError(f"must be finite, got {v!r}")
    return float(v)


def _integer(v: Any) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or v != int(v):
        raise ValueError(f"expected an integer, got {v!r}")
    return int(v)


def _boolean(v: Any) -> bool:
    if not isinstance(v, bool):
        raise ValueError(f"expected true/false, got {v!r}")
    return v


def _effect_specs(specs: Any) -> tuple:
    if specs is None:
        return ()
    if not isinstance(specs, (list, tuple)):
        raise ValueError("expected a list of {kind, params...}")
    from plant.effects import build_effect

    out = []
    for i, spec in enumerate(specs):
        if not isinstance(spec, dict) or "kind" not in spec:
            raise ValueError(f"[{i}]: expected a mapping with a 'kind' key")
        try:  # validate now so a bad scenario fails at load time
            build_effect(dict(spec))
        except ValueError as exc:
            raise ValueError(f"[{i}]: {exc}") from None
        out.append(dict(spec))
    return tuple(out)


Number = Annotated[float, BeforeValidator(_number)]
Positive = Annotated[float, BeforeValidator(_number), Field(gt=0)]
NonNegative = Annotated[float, BeforeValidator(_number), Field(ge=0)]
PositiveInt = Annotated[int, BeforeValidator(_integer), Field(gt=0)]
Switch = Annotated[bool, BeforeValidator(_boolean)]
CounterFraction = Annotated[float, BeforeValidator(_number), AfterValidator(check_counter_fraction)]
EffectSpecs = Annotated[tuple, BeforeValidator(_effect_specs)]
_CFG = ConfigDict(extra="forbid")


# --------------------------------------------------------------------------- typed objects


@dataclass(frozen=True, config=_CFG)
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

    resistance_ohm: Positive
    inductance_h: Positive
    torque_constant_nm_a: Positive
    rotor_inertia_kg_m2: Positive
    viscous_nm_s_rad: NonNegative
    rated_current_a: Positive
    supply_v: Positive
    shunt_ohm: Positive


@dataclass(frozen=True, config=_CFG)
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

    ratio: Positive
    backlash_motor_deg: NonNegative
    stiffness_nm_rad: Positive
    damping_ratio: NonNegative

    @property
    def backlash_rad(self) -> float:
        """Total dead-zone width of one train at the axis [rad] = backlash_motor_deg / ratio."""
        return math.radians(self.backlash_motor_deg) / self.ratio

    @property
    def train_stiffness_nm_rad(self) -> float:
        """Stiffness of one train at the axis [N·m/rad] (half the Table 1 value)."""
        return 0.5 * self.stiffness_nm_rad


@dataclass(frozen=True, config=_CFG)
class DriveParameters:
    """The twin-motor preload law carried for the firmware (paper §3.3).

    Attributes
    ----------
    preload_law : str
        ``"proportional"``: counter duty = ``counter_fraction`` × |U|.
    counter_fraction : float
        p, 0.10–0.25 (paper §3.3; Table 1 "Counter torque (25%)").
    """

    preload_law: Literal["proportional"]
    counter_fraction: CounterFraction


@dataclass(frozen=True, config=_CFG)
class FrictionSet:
    """One Table 2 LuGre set (paper §4): σ2 [N·m·s/rad], Tc, Ts [N·m], ωs [rad/s]."""

    sigma2_nm_s_rad: NonNegative
    tc_nm: NonNegative
    ts_nm: NonNegative
    omega_s_rad_s: Positive


@dataclass(frozen=True, config=_CFG)
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

    preload: Literal["low", "high"]
    sigma0_nm_rad: Positive
    sigma1_nm_s_rad: NonNegative
    delta: Positive
    low: FrictionSet
    high: FrictionSet
    tc_pos_nm: NonNegative | None = None
    tc_neg_nm: NonNegative | None = None
    sigma2_pos_nm_s_rad: NonNegative | None = None
    sigma2_neg_nm_s_rad: NonNegative | None = None

    @property
    def active(self) -> FrictionSet:
        """The Table 2 set selected by ``preload``."""
        return self.low if self.preload == "low" else self.high


@dataclass(frozen=True, config=_CFG)
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

    incremental_counts_per_rev: PositiveInt
    roller_ratio: Positive
    incremental_error_arcsec: NonNegative
    absolute_bits: PositiveInt

    @property
    def counts_per_axis_rev(self) -> float:
        """Incremental counts per axis revolution (1.12896e8)."""
        return self.incremental_counts_per_rev * self.roller_ratio

    @property
    def arcsec_per_count(self) -> float:
        """Incremental resolution at the axis [arcsec/count] (0.01148)."""
        return ARCSEC_PER_REV / self.counts_per_axis_rev


# -- issue 12: motor tachometers and the auxiliary encoder --------------------------------------
@dataclass(frozen=True, config=_CFG)
class TachometerParameters:
    """The CP-850 incremental encoder on each motor shaft, used as a digital tachometer (§3.2).

    Attributes
    ----------
    counts_per_rev : int
        Quadrature counts per motor revolution (assumed; see the leaf's source).
    """

    counts_per_rev: PositiveInt


@dataclass(frozen=True, config=_CFG)
class AuxEncoderParameters:
    """The auxiliary absolute encoder: 17-bit Gurley A25S through a 1:10.8 reduction, ±15″ (§3.2).

    The error model (at the encoder shaft, angle φe = reduction · θ):
    ``e(φe) = a1·sin(φe + p1) + a2·sin(2φe + p2) + n``, ``n`` Gaussian with standard deviation
    ``noise_arcsec`` (seeded), then quantised to the 17-bit word. See :meth:`plant.axis.AxisPlant.aux_encoder_word`.

    Attributes
    ----------
    bits : int
        Single-turn word width, 17.
    reduction : float
        Encoder turns per axis turn, 10.8.
    once_per_rev_arcsec, twice_per_rev_arcsec : float
        Amplitudes of the once- and twice-per-encoder-revolution errors [arcsec at the encoder shaft].
    once_per_rev_phase_rad, twice_per_rev_phase_rad : float
        Their phases [rad].
    noise_arcsec : float
        Standard deviation of the read noise [arcsec at the encoder shaft].
    """

    bits: PositiveInt
    reduction: Positive
    once_per_rev_arcsec: NonNegative
    once_per_rev_phase_rad: Number
    twice_per_rev_arcsec: NonNegative
    twice_per_rev_phase_rad: Number
    noise_arcsec: NonNegative

    @property
    def counts_per_axis_rev(self) -> float:
        """Encoder counts per axis revolution (2**17 · 10.8 = 1 415 577.6)."""
        return (1 << self.bits) * self.reduction

    @property
    def arcsec_per_count(self) -> float:
        """Resolution at the axis [arcsec/count] (0.9155″)."""
        return ARCSEC_PER_REV / self.counts_per_axis_rev
# -- end issue 12 ---------------------------------------------------------------------------------


@dataclass(frozen=True, config=_CFG)
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
    motor, gear, drive, friction, encoders, tachometer, aux_encoder
        Sub-sections.
    effects : tuple of dict
        Effect specs ``{kind, **params}`` (built by :func:`plant.effects.build_effect`).
    perfect : bool
        Copy of the file's top-level ``perfect`` switch.
    gear_disturbance : dict
        Gear-train torque lines ``{line: {amplitude_nm, phase…_rad}}``, validated by
        :func:`plant.gear_train_disturbance.parse_section` (its schema lives there; empty when the
        file has no section).
    """

    name: Literal["ra", "dec"]
    inertia_kg_m2: Positive
    max_substep_us: PositiveInt
    drive_model: Literal["twin_train", "rigid"]
    motor: MotorParameters
    gear: GearParameters
    drive: DriveParameters
    friction: FrictionParameters
    encoders: EncoderParameters
    tachometer: TachometerParameters
    aux_encoder: AuxEncoderParameters
    effects: EffectSpecs
    perfect: Switch = False
    gear_disturbance: dict = field(default_factory=dict)

    @property
    def reflected_motor_inertia_kg_m2(self) -> float:
        """Inertia of both rotors seen at the axis, 2·Jm·N² [kg·m²]."""
        return 2.0 * self.motor.rotor_inertia_kg_m2 * self.gear.ratio ** 2


@dataclass(frozen=True, config=_CFG)
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

    screw_lead_m: Positive
    belt_ratio: Positive
    halfstep_angle_deg: Positive
    travel_m: Positive
    lvdt_center_v: Number
    lvdt_span_v: Positive
    adc_bits: PositiveInt
    motor_encoder_counts_per_rev: PositiveInt
    index_offset_m: Number

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


# -- issue 12, room nodes: site, dome, weather, display -----------------------------------------
Latitude = Annotated[float, BeforeValidator(_number), Field(ge=-90, le=90)]
Longitude = Annotated[float, BeforeValidator(_number), Field(ge=-180, le=180)]
Fraction = Annotated[float, BeforeValidator(_number), Field(ge=0, le=1)]
Azimuth = Annotated[float, BeforeValidator(_number), Field(ge=0, lt=360)]
Percent = Annotated[float, BeforeValidator(_number), Field(ge=0, le=100)]


@dataclass(frozen=True, config=_CFG)
class SiteParameters:
    """The observatory site (paper §2: 29°22' N, 79°27' E, ARIES Manora Peak, Nainital).

    Attributes
    ----------
    latitude_deg, longitude_deg : float
        Geodetic latitude (north +) and longitude (east +) [deg].
    """

    latitude_deg: Latitude
    longitude_deg: Longitude


@dataclass(frozen=True, config=_CFG)
class DomeParameters:
    """The dome: its azimuth drive limits (firmware) and its plant (:class:`plant.dome.DomePlant`).

    Attributes
    ----------
    max_rate_deg_s : float
        Azimuth rate limit the dome firmware commands at most [deg/s].
    acceleration_deg_s2 : float
        Azimuth acceleration limit of the firmware's rate ramp [deg/s²].
    deadband_deg : float
        The dome starts moving when the slit is off target by more than this [deg].
    park_azimuth_deg : float
        Azimuth PARK drives to [deg, N = 0, E = 90].
    initial_azimuth_deg : float
        Azimuth of the dome at power-on [deg].
    vfd_full_scale_deg_s : float
        Dome rotation rate at full-scale speed reference of the drive (the DAC's ±1) [deg/s].
    encoder_counts_per_rev : int
        Absolute azimuth encoder counts per dome revolution.
    dac_bits : int
        Resolution of the firmware's speed-reference DAC.
    control_period_us : int
        The dome firmware's control loop period [µs].
    position_timeout_us : int
        FOLLOW holds (POSITION_STALE) when no POSITION frame of an axis arrived for this long [µs].
    """

    max_rate_deg_s: Positive
    acceleration_deg_s2: Positive
    deadband_deg: Positive
    park_azimuth_deg: Azimuth
    initial_azimuth_deg: Azimuth
    vfd_full_scale_deg_s: Positive
    encoder_counts_per_rev: PositiveInt
    dac_bits: PositiveInt
    control_period_us: PositiveInt
    position_timeout_us: PositiveInt


@dataclass(frozen=True, config=_CFG)
class WeatherParameters:
    """The weather at the site (:class:`plant.weather.WeatherModel`), the station's sensors and
    its thresholds (firmware, :class:`boards.weather.WeatherStation`).

    Attributes
    ----------
    sample_period_us : int
        Step of the time series and the station's sampling period [µs].
    temperature_mean_c, temperature_diurnal_c, temperature_noise_c : float
        Mean, diurnal half-amplitude (maximum at 14 h local) and AR(1) noise std [°C].
    start_local_hour : float
        Local solar hour at simulated t = 0 [h].
    humidity_mean_pct, humidity_noise_pct : float
        Mean and stationary std of the relative humidity [%] (clipped to 0..100).
    humidity_tau_s : float
        Correlation time of the humidity process [s].
    wind_mean_m_s, wind_noise_m_s, wind_tau_s : float
        Mean, stationary std and correlation time of the wind speed (Ornstein–Uhlenbeck,
        clipped at 0) [m/s, s].
    rain_rate_per_h, rain_duration_s : float
        Seeded rain episodes: Poisson rate [1/h] (0 = none) and length [s].
    high_wind_limit_m_s, high_wind_clear_m_s : float
        HIGH_WIND sets at or above the limit and clears after the wind stayed below the clear
        level for ``clear_hold_s`` [m/s].
    humidity_limit_pct : float
        RAIN also sets at or above this relative humidity [%].
    clear_hold_s : float
        A flag clears only after its condition was absent this long [s].
    temperature_min_c, temperature_max_c : float
        Temperature at 0 V and 5 V of the station's temperature input [°C].
    wind_full_scale_m_s : float
        Wind speed at 5 V of the anemometer's analog output [m/s].
    """

    sample_period_us: PositiveInt
    temperature_mean_c: Number
    temperature_diurnal_c: NonNegative
    temperature_noise_c: NonNegative
    start_local_hour: Annotated[float, BeforeValidator(_number), Field(ge=0, lt=24)]
    humidity_mean_pct: Percent
    humidity_noise_pct: NonNegative
    humidity_tau_s: Positive
    wind_mean_m_s: NonNegative
    wind_noise_m_s: NonNegative
    wind_tau_s: Positive
    rain_rate_per_h: NonNegative
    rain_duration_s: Positive
    high_wind_limit_m_s: Positive
    high_wind_clear_m_s: NonNegative
    humidity_limit_pct: Percent
    clear_hold_s: NonNegative
    temperature_min_c: Number
    temperature_max_c: Number
    wind_full_scale_m_s: Positive


@dataclass(frozen=True, config=_CFG)
class DisplayParameters:
    """The digital display unit (firmware, :class:`boards.display.DisplayUnit`).

    Attributes
    ----------
    refresh_period_us : int
        One refresh of the display (and one display-log line) per period [µs].
    stale_timeout_us : int
        An input older than this is shown as dashes [µs].
    """

    refresh_period_us: PositiveInt
    stale_timeout_us: PositiveInt
# -- end room nodes


def _check_axes(axes: dict) -> dict:
    if tuple(sorted(axes)) != tuple(sorted(AXIS_NAMES)):
        raise ValueError(f"expected exactly the axes {list(AXIS_NAMES)}, got {sorted(axes)}")
    return axes


@dataclass(frozen=True, config=_CFG)
class PlantParameters:
    """The whole parameter file, typed.

    Attributes
    ----------
    perfect : bool
        The top-level switch (see :mod:`plant.axis` and docs/plant.md).
    axes : dict[str, AxisParameters]
        ``"ra"`` and ``"dec"``.
    focus : FocusParameters
    site, dome, weather, display : SiteParameters, DomeParameters, WeatherParameters, DisplayParameters
        The room nodes of issue 12 (dome, weather station, display unit) and the site.
    tree : dict
        The raw file tree (with overrides applied); units and sources for :func:`dump_parameters`.
    """

    perfect: Switch
    axes: Annotated[dict[str, AxisParameters], AfterValidator(_check_axes)]
    focus: FocusParameters
    site: SiteParameters            # issue 12, room nodes
    dome: DomeParameters
    weather: WeatherParameters
    display: DisplayParameters
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


#: Sections validated by their own module, kept as they are by :func:`_values`.
_RAW_SECTIONS = ("effects", "gear_disturbance")


def _values(node: Any, path: str) -> Any:
    """The file tree with every ``{value, unit, source}`` leaf replaced by its value (effect
    lists kept as they are)."""
    if _is_leaf(node):
        return node["value"]
    if isinstance(node, dict):
        return {k: _values(v, f"{path}.{k}" if path else k) if k not in _RAW_SECTIONS else v
                for k, v in node.items()}
    raise ParameterError(f"{path or '<root>'}: expected a leaf {{value, unit, source}} or a section, got {node!r}")


def _dotted(loc: tuple) -> str:
    return ".".join(str(p) for p in loc if not (isinstance(p, str) and p.endswith("]")))


def _first_error(exc: ValidationError, values: dict) -> str:
    """One line for the first error: the dotted path and what was expected."""
    errs = sorted(exc.errors(), key=lambda e: e["type"] != "unexpected_keyword_argument")
    e = errs[0]
    loc = tuple(str(p) for p in e["loc"])
    path = ".".join(loc) or "<root>"
    if e["type"] in ("unexpected_keyword_argument", "extra_forbidden"):
        return f"{path}: unknown key; valid keys: {_valid_keys(loc[:-1])}"
    if e["type"] in ("missing", "missing_argument"):
        parent = _node_at(values, loc[:-1])
        return f"{path}: missing; present keys: {_keys(parent)}"
    msg = e["msg"].removeprefix("Value error, ")
    return f"{path}: {msg}" + (f" (got {e['input']!r})" if "got" not in msg and "input" in e else "")


def _valid_keys(loc: tuple) -> list[str]:
    """Field names of the typed class at ``loc`` (the axis name and perfect switch excluded)."""
    cls: Any = PlantParameters
    for part in loc:
        if cls is PlantParameters and part == "axes":
            cls = AxisParameters
            continue
        if part in AXIS_NAMES and cls is AxisParameters:
            continue
        cls = cls.__pydantic_fields__[part].annotation
    return sorted(k for k in cls.__pydantic_fields__ if k not in ("name", "tree") and not (k == "perfect" and cls is AxisParameters))


def _node_at(tree: Any, loc: tuple) -> Any:
    for part in loc:
        tree = tree.get(part) if isinstance(tree, dict) else None
    return tree


_PLANT = TypeAdapter(PlantParameters)


def _gear_disturbance(node: Any, axis: str) -> dict:
    """The gear-line section of one axis, validated by its own schema
    (:func:`plant.gear_train_disturbance.parse_section`), as plain floats."""
    from plant.gear_train_disturbance import parse_section

    try:
        return parse_section(node, f"axes.{axis}.gear_disturbance")
    except ValueError as exc:
        raise ParameterError(str(exc)) from None


def parameters_from_tree(tree: dict) -> PlantParameters:
    """Build typed parameters from a parsed file tree (no overrides), validated against the
    typed classes above (one schema).

    Raises
    ------
    ParameterError
        Missing/unknown keys, wrong types or out-of-range values (message names the path).
    """
    if not isinstance(tree, dict):
        raise ParameterError("<root>: expected a mapping")
    schema = tree.get("schema")
    if not _is_leaf(schema) or schema["value"] != SCHEMA:
        raise ParameterError(f"schema: expected {{value: {SCHEMA}}}, got {schema!r}")
    values = _values({k: v for k, v in tree.items() if k != "schema"}, "")
    axes = values.get("axes")
    if isinstance(axes, dict) and sorted(axes) != sorted(AXIS_NAMES):
        raise ParameterError(f"axes: expected exactly the axes {list(AXIS_NAMES)}, got {sorted(axes)}")
    if isinstance(axes, dict):
        for name, axis in axes.items():
            if isinstance(axis, dict):  # the axis name and the file's perfect switch go into each axis
                axis.update(name=name, perfect=values.get("perfect", False))
                axis["gear_disturbance"] = _gear_disturbance(axis.get("gear_disturbance"), name)
    try:
        return _PLANT.validate_python({**values, "tree": tree})
    except ValidationError as exc:
        raise ParameterError(_first_error(exc, values)) from None


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
                child["value"] = v
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
