"""Scenario files: YAML, validated on load, errors naming file, line and key.

A scenario says which telescope to build (bus, plant parameters, controller overrides, log rate)
and what to do with it (a list of segments run one after another). It is validated completely
before anything runs: an unknown key or a bad value raises :class:`ScenarioError` with the file,
the line and the dotted key, so nothing runs half-way.

Example::

    name: tracking-low-preload
    seed: 1
    plant:
      preload: low
    segments:
      - name: track
        axis: ra
        mode: track
        duration_s: 80
        settle_s: 20
"""

from __future__ import annotations

import dataclasses
import math

from pathlib import Path
from typing import Annotated, Any, Literal

import yaml
from pydantic import AfterValidator, BaseModel, PrivateAttr, ConfigDict, Field, ValidationError, field_validator, model_validator

from boards.endat import FRAME_BITS as ENDAT_FRAME_BITS
from boards.registry import BOARD_NAMES, BOARDS, network_boards
from boards.safety import DEFAULT_SAFETY, SafetyLimits
from bus.errors import ConfigurationError
from bus.units import check_counter_fraction
from host.faults import FAULT_KINDS, FAULT_PARAMS, FAULTS, check_fault
from plant.params import ParameterError, PlantParameters, load_parameters

__all__ = [
    "ScenarioError",
    "Scenario",
    "Segment",
    "load_scenario",
    "parse_scenario",
    "MODES",
    "resolve_parameters",
]

#: Axis motion modes a segment may command (paper §3.3: slew, set, guide, fine, track; plus an
#: arbitrary velocity, the open-loop runs of §4 and stop).
MODES = ("stop", "slew", "set", "guide", "fine", "track", "velocity", "open_loop")


class ScenarioError(ConfigurationError):
    """A scenario file is invalid.

    Parameters
    ----------
    path : str
        The scenario file.
    line : int or None
        1-based line of the offending key or value, when known.
    key : str
        Dotted path of the offending key (``segments[2].mode``).
    problem : str
        What was expected.
    """

    def __init__(self, path: str, line: int | None, key: str, problem: str):
        self.path, self.line, self.key, self.problem = path, line, key, problem
        where = f"{path}:{line}" if line else path
        super().__init__(f"{where}: {key}: {problem}" if key else f"{where}: {problem}")


#: Limits checked before anything runs (issue 11: a scenario that cannot finish must not start).
#: Assumed: a scenario is a hand-written test plan; these are far above any in scenarios/.
MAX_SCENARIO_BYTES = 1 << 20       # 1 MiB of YAML
MAX_SEGMENTS = 10_000
MAX_FAULTS = 10_000
MAX_DURATION_S = 7 * 86_400.0      # a week of simulated time
MAX_YAML_NODES = 200_000           # nodes of the YAML document (anchors/aliases refused outright)


class _Strict(BaseModel):
    # non-finite numbers (.inf, .nan) are refused everywhere: they would fail half-way through a run
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class BusConfig(_Strict):
    """Which CAN bus the network uses.

    ``sim`` is the in-process emulated bus in simulated time (CAN 2.0A bit timing, arbitration,
    bus load). ``virtual`` is python-can's virtual bus, one Bus object per board (no bit timing;
    the naive design, kept for comparison and to prove the boards run on a plain python-can bus).
    ``socketcan`` uses a real ``vcan0``/``can0`` in real time (needs ``AF_CAN``: see docs).
    """

    interface: Literal["sim", "virtual", "socketcan"] = "sim"
    channel: str = "telescope"
    bitrate: int = Field(1_000_000, gt=0, le=1_000_000)


class PlantConfig(_Strict):
    """Plant parameters: the packaged parameter file, or another (e.g. calibrated) one, plus
    dotted overrides (``axes.ra.friction.sigma0_nm_rad: 2.0e8``). An override's value may be a list
    (``axes.ra.effects: [{kind: position_periodic, ...}]``), so a scenario adds plant effects
    without copying the parameter file."""

    parameter_file: str | None = None
    preload: Literal["low", "high"] | None = None
    perfect: bool | None = None
    overrides: dict[str, float | int | str | bool | list[dict[str, Any]]] = Field(default_factory=dict)


class AxisControllerConfig(_Strict):
    """Per-axis controller overrides; unset values come from the tuning rule and parameter file."""

    kp: float | None = Field(None, ge=0, description="duty per (arcsec/s)")
    ki: float | None = Field(None, ge=0, description="duty per (arcsec/s) per tick")
    counter_fraction: Annotated[float, AfterValidator(check_counter_fraction)] | None = None  # bus.units: [0, 1)
    u_max: float | None = Field(None, gt=0.0, le=1.0)


class ControllerConfig(_Strict):
    ra: AxisControllerConfig = Field(default_factory=AxisControllerConfig)
    dec: AxisControllerConfig = Field(default_factory=AxisControllerConfig)


class LogConfig(_Strict):
    """The four ASCII logs of paper §5.2; ``rate_hz`` is the sensor-data log rate."""

    rate_hz: float = Field(100.0, gt=0, le=200.0)


#: Standard PC serial-port rates a scenario may pick for the RS232 links, baud.
RS232_BAUDS = (38_400, 57_600, 115_200, 230_400, 460_800, 921_600)


class Rs232Config(_Strict):
    """RS232 telemetry links of paper §3.4 (each board → the PC's hub, packets every 250 ms).

    ``enabled`` wires a serial link per board and writes ``telemetry.log``. Default **off**: the
    paper's characterisation setup streamed it continuously, but recording 500 samples/s and
    moving 20 packets/s costs ≈ 1.5 ms of CPU per simulated second (≈ 11 % of the tracking
    scenario's run time, measured), and in the emulator the same quantities already reach the
    host over CAN every 10 ms. ``baud`` is the line rate (8N1); rates below 38 400 are refused because the largest packet (axis controller,
    566 bytes = 5660 bits on the wire) would not fit in the 250 ms interval (at 19 200 baud it
    takes 295 ms). See docs/protocol.md "RS232 telemetry" for the budget.
    """

    enabled: bool = False
    baud: Literal[38_400, 57_600, 115_200, 230_400, 460_800, 921_600] = 115_200


class ReportConfig(_Strict):
    """How velocity errors are measured for the report (see host/report.py)."""

    velocity_window_ms: int = Field(100, ge=10, le=10_000)


# -- issue 12, room nodes: the weather station's time series -------------------------------------
class WeatherEventConfig(_Strict):
    """A scripted weather event (``plant.weather.WeatherEvent``): ``gust`` raises the wind to at
    least ``wind_m_s`` for ``duration_s``; ``rain`` wets the rain sensor for ``duration_s``.
    ``at_s`` is simulated time since power-on (t = 0)."""

    at_s: float = Field(ge=0)
    kind: Literal["gust", "rain"]
    duration_s: float = Field(gt=0, le=86_400)
    wind_m_s: float | None = Field(None, ge=0, le=100)

    @model_validator(mode="after")
    def _check(self) -> "WeatherEventConfig":
        if self.kind == "gust" and self.wind_m_s is None:
            raise ValueError("a gust needs wind_m_s")
        if self.kind == "rain" and self.wind_m_s is not None:
            raise ValueError("wind_m_s is only for a gust")
        return self


class WeatherConfig(_Strict):
    """The weather the weather station measures (used when the network has the station):
    the seeded series of ``plant/weather.py`` (its parameters: ``plant.overrides`` under
    ``weather.*``) with ``seed`` (default: the scenario's ``seed``) and scripted ``events``."""

    seed: int | None = None
    events: list[WeatherEventConfig] = Field(default_factory=list, max_length=10_000)
# -- end room nodes


class Segment(_Strict):
    """One step of a scenario: command one axis (or both) and hold for ``duration_s``.

    ``settle_s`` is excluded from the error statistics. ``rate_arcsec_s`` is required for
    ``velocity`` and ``open_loop`` and forbidden for the presets (their rates are firmware
    constants, see ``boards.axis_controller``).
    """

    name: str
    axis: Literal["ra", "dec", "both"] = "ra"
    mode: Literal["stop", "slew", "set", "guide", "fine", "track", "velocity", "open_loop"]
    direction: Literal[1, -1] = 1
    rate_arcsec_s: float | None = Field(None, gt=0, le=DEFAULT_SAFETY.max_rate_arcsec_s,
                                        description="the firmware refuses faster (boards/safety.py)")
    duration_s: float = Field(gt=0, le=3600)
    settle_s: float = Field(0.0, ge=0)
    focus_halfsteps: int | None = None
    dome: Literal["follow", "park", "stop"] | None = Field(
        None, description="issue 12: a DOME_COMMAND sent with the segment (needs the dome in the network)")

    @model_validator(mode="after")
    def _check(self) -> "Segment":
        if self.mode in ("velocity", "open_loop") and self.rate_arcsec_s is None:
            raise ValueError(f"mode '{self.mode}' needs rate_arcsec_s (> 0)")
        if self.mode not in ("velocity", "open_loop") and self.rate_arcsec_s is not None:
            raise ValueError(
                f"rate_arcsec_s is only for modes velocity/open_loop; '{self.mode}' uses its preset rate"
            )
        if self.settle_s >= self.duration_s and self.mode != "stop":
            raise ValueError("settle_s must be shorter than duration_s")
        return self


class Fault(_Strict):
    """A fault injected at a simulated time (fault-handling tests). Kinds, the boards each
    applies to and its parameters: the fault table :data:`host.faults.FAULTS`. A new parameter
    is one field here and one name in :data:`host.faults.FAULT_PARAMS`."""

    at_s: float = Field(ge=0, allow_inf_nan=False)
    kind: Literal[FAULT_KINDS]  # the fault table of host/faults.py
    board: Literal[BOARD_NAMES] | None = None  # the board registry (boards/registry.py)
    bit: int | None = Field(None, ge=0, le=ENDAT_FRAME_BITS - 1, description="endat_bit_flip: bit of the frame")
    halfsteps: int | None = Field(None, ge=1, le=100_000, description="focus_stall: half-steps lost")
    ids: list[Annotated[int, Field(ge=0, le=0x7FF)]] | None = Field(None, max_length=2048,
                                                                    description="can_error/frame_loss: 11-bit ids (all if absent)")
    probability: float | None = Field(None, gt=0, le=1, allow_inf_nan=False)
    count: int | None = Field(None, ge=1, le=1_000_000)
    duration_s: float | None = Field(None, gt=0, le=86_400, allow_inf_nan=False)
    arbitration_id: int | None = Field(None, ge=0, le=0x7FF)
    auto_recover: bool | None = None

    @model_validator(mode="after")
    def _check(self) -> "Fault":
        check_fault(self.kind, self.board, {name: getattr(self, name) for name in FAULT_PARAMS})
        return self


def safety_limits(overrides: dict) -> SafetyLimits:
    """``DEFAULT_SAFETY`` with ``overrides`` (field name -> value).

    Raises
    ------
    ValueError
        Unknown field (the message lists the known ones), a non-finite number, or a value
        ``SafetyLimits`` refuses.
    """
    known = {f.name for f in dataclasses.fields(SafetyLimits)}
    for key, value in overrides.items():
        if key not in known:
            raise ValueError(f"unknown safety key '{key}' (expected one of: {', '.join(sorted(known))})")
        if value is None and key != "host_watchdog_us":
            raise ValueError(f"safety.{key}: null is only allowed for host_watchdog_us")
        if isinstance(value, float) and not math.isfinite(value):
            raise ValueError(f"safety.{key}: expected a finite number, got {value}")
    kw = {}
    for key, value in overrides.items():
        if value is not None and (key.endswith("_us") or key.endswith("_ticks")):
            if not float(value).is_integer():
                raise ValueError(f"safety.{key}: expected an integer, got {value}")
            value = int(value)
        kw[key] = value
    return dataclasses.replace(DEFAULT_SAFETY, **kw)


class Scenario(_Strict):
    """A validated scenario. Build with :func:`load_scenario`."""

    name: str
    description: str = ""
    seed: int = 0
    #: issue 12: which boards the network has: a name of ``boards.registry.NETWORKS``
    #: (``basic`` = today's five boards + gateway, ``lab``, ``full``) or a list of board names
    network: str | list[str] = "basic"
    bus: BusConfig = Field(default_factory=BusConfig)
    plant: PlantConfig = Field(default_factory=PlantConfig)
    controller: ControllerConfig = Field(default_factory=ControllerConfig)
    #: Overrides of the firmware's safety limits (``boards.safety.SafetyLimits`` field names:
    #: watchdog times, braking ramp, bounds; ``host_watchdog_us: null`` disables the host watchdog).
    safety: dict[str, float | int | None] = Field(default_factory=dict, max_length=32)
    log: LogConfig = Field(default_factory=LogConfig)
    rs232: Rs232Config = Field(default_factory=Rs232Config)
    report: ReportConfig = Field(default_factory=ReportConfig)
    weather: WeatherConfig = Field(default_factory=WeatherConfig)   # issue 12, room nodes
    faults: list[Fault] = Field(default_factory=list, max_length=MAX_FAULTS)
    segments: list[Segment] = Field(min_length=1, max_length=MAX_SEGMENTS)
    source_path: str = Field("<string>", exclude=True)
    #: (plant section, source path, parameters) resolved when the scenario was loaded, so the
    #: parameter file is read once; a copy with another plant section resolves again.
    _resolved: tuple | None = PrivateAttr(default=None)

    @field_validator("safety")
    @classmethod
    def _check_safety(cls, d: dict) -> dict:
        safety_limits(d)                       # raises ValueError naming the key
        return d

    def safety_limits(self) -> SafetyLimits:
        """The firmware's :class:`boards.safety.SafetyLimits` with this scenario's overrides."""
        return safety_limits(self.safety)

    @field_validator("segments")
    @classmethod
    def _unique_names(cls, segs: list[Segment]) -> list[Segment]:
        seen: set[str] = set()
        for s in segs:
            if s.name in seen:
                raise ValueError(f"duplicate segment name '{s.name}'")
            seen.add(s.name)
        return segs

    @field_validator("network")
    @classmethod
    def _check_network(cls, net):
        try:
            names = network_boards(net)
        except (KeyError, ValueError) as exc:
            raise ValueError(str(exc).strip("'\"")) from None
        axes = [n for n, (s, _) in BOARDS.items() if s.kind == "axis_controller"]
        missing = [a for a in axes if a not in names]
        if missing:
            raise ValueError(f"the network must hold the axis controllers (the host commands them); "
                             f"missing {', '.join(missing)}")
        return net

    @property
    def network_name(self) -> str:
        """The network's name, or ``"custom"`` for an explicit list of boards."""
        return self.network if isinstance(self.network, str) else "custom"

    @property
    def board_names(self) -> tuple[str, ...]:
        """The boards of :attr:`network`, in node order."""
        return network_boards(self.network)

    @model_validator(mode="after")
    def _check_faults(self) -> "Scenario":
        total = self.duration_s
        chosen = self.board_names
        for i, f in enumerate(self.faults):
            if f.board is not None and f.board not in chosen:
                raise ValueError(f"faults[{i}].board {f.board!r} is not on the network "
                                 f"{self.network_name!r} ({', '.join(chosen)})")
        if total > MAX_DURATION_S:
            raise ValueError(f"the segments last {total:.0f} s; at most {MAX_DURATION_S:.0f} s per run")
        for i, e in enumerate(self.weather.events):
            if e.at_s > total:
                raise ValueError(f"weather.events[{i}].at_s = {e.at_s} s is after the end of the run ({total} s)")
        for i, f in enumerate(self.faults):
            if f.at_s > total:
                raise ValueError(f"faults[{i}].at_s = {f.at_s} s is after the end of the run ({total} s)")
            if FAULTS[f.kind].sim_bus and self.bus.interface != "sim":
                raise ValueError(f"faults[{i}]: {f.kind} needs the emulated bus model (bus.interface: sim), "
                                 f"not {self.bus.interface}")
        return self

    @property
    def duration_s(self) -> float:
        """Total simulated duration of all segments [s]."""
        return sum(s.duration_s for s in self.segments)


def _line_index(node: yaml.Node, prefix: tuple = (), out: dict | None = None) -> dict:
    """Map every key path (tuple of str/int) to the 1-based line of its key or item."""
    out = {} if out is None else out
    if isinstance(node, yaml.MappingNode):
        for k, v in node.value:
            path = prefix + (k.value,)
            out[path] = k.start_mark.line + 1
            _line_index(v, path, out)
    elif isinstance(node, yaml.SequenceNode):
        for i, v in enumerate(node.value):
            path = prefix + (i,)
            out[path] = v.start_mark.line + 1
            _line_index(v, path, out)
    return out


def _dotted(loc: tuple) -> str:
    s = ""
    for part in loc:
        if isinstance(part, int):
            s += f"[{part}]"
        else:
            s += ("." if s else "") + str(part)
    return s


class _NoAliasLoader(yaml.SafeLoader):
    """``yaml.SafeLoader`` that refuses anchors/aliases (a few lines of aliases can expand to
    gigabytes: the "billion laughs") and documents of more than :data:`MAX_YAML_NODES` nodes."""

    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent):
            ev = self.peek_event()
            raise yaml.composer.ComposerError(None, None, "YAML aliases (*name) are not allowed in a scenario",
                                              ev.start_mark)
        self._nodes = getattr(self, "_nodes", 0) + 1
        if self._nodes > MAX_YAML_NODES:
            raise yaml.composer.ComposerError(None, None, f"more than {MAX_YAML_NODES} YAML nodes",
                                              self.peek_event().start_mark)
        return super().compose_node(parent, index)


def parse_scenario(text: str, path: str = "<string>") -> Scenario:
    """Parse and validate scenario YAML text.

    Parameters
    ----------
    text : str
        YAML document.
    path : str
        Name used in error messages and to resolve relative ``plant.parameter_file``.

    Returns
    -------
    Scenario

    Raises
    ------
    ScenarioError
        YAML syntax error, unknown key, wrong type or out-of-range value; the message names the
        file, the line and the dotted key.
    """
    if len(text.encode("utf-8", "replace")) > MAX_SCENARIO_BYTES:
        raise ScenarioError(path, None, "", f"file is larger than {MAX_SCENARIO_BYTES} bytes (the limit for a scenario)")
    try:
        node = yaml.compose(text, Loader=_NoAliasLoader)
        data = yaml.load(text, Loader=_NoAliasLoader)  # noqa: S506 - a SafeLoader subclass
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise ScenarioError(path, mark.line + 1 if mark else None, "", f"YAML syntax: {problem}") from None
    if not isinstance(data, dict):
        raise ScenarioError(path, 1, "", "expected a mapping at the top level (name, segments, ...)")
    lines = _line_index(node) if node is not None else {}
    try:
        scenario = Scenario.model_validate({**data, "source_path": path})
    except ValidationError as exc:
        # an unknown key first: a misspelt key is usually why a required one is "missing"
        errs = sorted(exc.errors(), key=lambda e: e["type"] != "extra_forbidden")
        err = errs[0]
        loc = tuple(err["loc"])
        line = None
        for n in range(len(loc), 0, -1):
            line = lines.get(tuple(loc[:n]))
            if line:
                break
        problem = err["msg"].removeprefix("Value error, ")
        if err["type"] == "extra_forbidden":
            problem = f"unknown key; {_valid_keys_hint(loc)}"
        elif "input" in err and err["type"] not in ("missing", "value_error"):
            problem = f"{problem} (got {err['input']!r})"
        raise ScenarioError(path, line, _dotted(loc), problem) from None
    # The plant parameter file and every override must resolve too, before anything runs.
    try:
        scenario._resolved = (scenario.plant, scenario.source_path, resolve_parameters(scenario))
    except ScenarioError as exc:
        if exc.line is None:
            prefix = ("plant", "overrides")
            if exc.key.startswith("plant.overrides."):
                loc = prefix + (exc.key[len("plant.overrides."):],)
            else:
                loc = ("plant", exc.key.split(".", 1)[1]) if exc.key.startswith("plant.") else ("plant",)
            line = lines.get(loc) or lines.get(loc[:2]) or lines.get(("plant",))
            raise ScenarioError(exc.path, line, exc.key, exc.problem) from None
        raise
    return scenario


def _valid_keys_hint(loc: tuple) -> str:
    model: Any = Scenario
    for part in loc[:-1]:
        if isinstance(part, int):
            continue
        field = model.model_fields.get(part)
        if field is None:
            return "see docs/scenarios.md"
        ann = field.annotation
        args = getattr(ann, "__args__", ())
        cand = [a for a in (ann, *args) if isinstance(a, type) and issubclass(a, BaseModel)]
        if not cand:
            return "see docs/scenarios.md"
        model = cand[0]
    keys = sorted(k for k in model.model_fields if k != "source_path")
    return "valid keys: " + ", ".join(keys)


def resolve_parameters(scenario: Scenario) -> PlantParameters:
    """Load the scenario's plant parameter file with its overrides (``plant.preload``,
    ``plant.perfect``, ``plant.overrides``): the parameters the plant will run. A scenario from
    :func:`parse_scenario` carries them already (the file is read once, at load time).

    Raises
    ------
    ScenarioError
        The parameter file is missing or an override names an unknown parameter (the message
        names the scenario file and the ``plant.overrides`` key).
    """
    cached = scenario._resolved
    if cached is not None and cached[0] == scenario.plant and cached[1] == scenario.source_path:
        return cached[2]                # resolved (and validated) when the scenario was loaded
    pc = scenario.plant
    path = None
    if pc.parameter_file:
        path = Path(pc.parameter_file)
        if not path.is_absolute():
            path = Path(scenario.source_path).parent / path
        if not path.exists():
            raise ScenarioError(scenario.source_path, None, "plant.parameter_file", f"file not found: {path}")
    overrides: dict = {}
    if pc.preload is not None:
        overrides["axes.ra.friction.preload"] = pc.preload
        overrides["axes.dec.friction.preload"] = pc.preload
    if pc.perfect is not None:
        overrides["perfect"] = pc.perfect
    overrides.update(pc.overrides)
    try:
        return load_parameters(path, overrides or None)
    except ParameterError as exc:
        key = next((k for k in pc.overrides if k in str(exc)), None)
        raise ScenarioError(scenario.source_path, None, f"plant.overrides.{key}" if key else "plant", str(exc)) from None


def load_scenario(path: str | Path) -> Scenario:
    """Load and validate a scenario file.

    Raises
    ------
    ScenarioError
        File missing or invalid (see :func:`parse_scenario`).
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise ScenarioError(str(p), None, "", f"cannot read scenario: {exc.strerror}") from None
    return parse_scenario(text, str(p))
