"""The host client: the operator PC on the CAN bus (the USB-to-CAN node of paper §3.4).

It talks to the boards only through the documented frames (``bus.protocol``, docs/protocol.md)
over any python-can ``BusABC``: power-on with a health check, motion commands, and the status it
decodes from what the boards publish. It never touches a board or the plant directly.

Weather (issue 12, docs/faults.md "Weather"): when the weather station's WEATHER_STATUS shows
HIGH_WIND or RAIN, the host stops the axes (STOP_ALL), parks the dome (DOME_COMMAND PARK, when
the network has a dome), and from then on refuses every motion command (axis modes other than
stop; dome follow/goto) with a line in ``commands.log`` (``REFUSED``) and ``errors.log``
(``command-refused``); it logs ``weather-unsafe`` when the condition appears and
``weather-clear`` when the station clears its flags. Nothing restarts by itself: the next
command after the clear is obeyed.

CANopen (docs/canopen.md): the host is node 0x10, the NMT master and the SDO client. Its
power-on health check is an SDO upload of object 0x1000 from every expected node (the answer on
0x580 + node replaces the old PING's heartbeat); then it starts the nodes with NMT start and
produces its own CiA heartbeat on 0x710 every second (the boards may consume it as the host
watchdog, object 0x1016).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, ClassVar, Final, Mapping

import can
from mypy_extensions import mypyc_attr

from bus import protocol as P
from bus.errors import MalformedFrame
from bus.scheduler import PRIO_HOST, Scheduler
from boards.registry import NODE_NAMES, REGISTRY, network_nodes, nodes_of_kind
from bus.units import ARCSEC_PER_REV, TICK_US, duty_to_q15, q15_to_duty

#: identifier -> decoder of the frame table (``bus.protocol.decode`` without its call, per frame)
#: decoder per 11-bit identifier, indexed by it (a list: no boxed integer key hashed per frame)
_DECODERS: Final[list[Any]] = [None] * 0x800
for _cob, _entry in P.COB_TABLE.items():
    _DECODERS[_cob] = _entry[1].decode
#: flag masks as plain ints (an IntFlag operation is a Python-level call, per frame)
_POSITION_BAD: Final = int(P.PositionFlags.CRC_ERROR | P.PositionFlags.INVALID)
_AUX_TURNS_UNKNOWN: Final = int(P.AuxFlags.TURNS_UNKNOWN)

__all__ = ["HostClient", "Health", "AxisState", "NODE_NAMES", "AXIS_NODES", "AdcCurrent"]

AXIS_NODES: Final = nodes_of_kind("axis_controller")       #: {"ra": 1, "dec": 2}
READER_NODES: Final = nodes_of_kind("position_reader")    #: {"ra": 3, "dec": 4}
_AXIS_OF_NODE: Final = {node: axis for axis, node in AXIS_NODES.items()}


#: node per 11-bit identifier (``bus.protocol.node_of`` as a list: no hashed key per frame)
_NODE_OF: Final[list[Any]] = [None] * 0x800
for _cob, _entry in P.COB_TABLE.items():
    _NODE_OF[_cob] = _entry[2]


def _node_of(cob_id: int) -> Any:
    """``bus.protocol.node_of`` (None only for broadcasts, which reach no handler that uses it),
    called natively (a module-level alias would go through Python's call protocol on every
    frame) and read from a list indexed by the identifier (session 23)."""
    if 0 <= cob_id < 0x800:
        return _NODE_OF[cob_id]
    return P.node_of(cob_id)


class AdcCurrent:
    """``adc_to_current_a`` of :class:`HostClient` for a board ADC and a shunt: counts → A as
    ``adc.to_volts(counts) / shunt_ohm`` (the same arithmetic), compiled so the host's two calls
    per AXIS_AUX frame are not interpreted lambdas (session 16, issue 12).

    Parameters
    ----------
    adc : boards.peripherals.Adc-like
        Its ``lsb_v`` [V per count] is read at every call, as ``to_volts`` does.
    shunt_ohm : float
        Current-sense shunt [Ω] (paper §3.3: 0.1 Ω; from the parameter file).
    """

    def __init__(self, adc: Any, shunt_ohm: float) -> None:
        self.adc = adc
        self.shunt_ohm = shunt_ohm

    def __call__(self, counts: int) -> float:
        return counts * self.adc.lsb_v / self.shunt_ohm


#: issue 12: tachometer node -> (axis, motor); auxiliary-encoder node -> axis (from the registry)
TACH_MOTOR_OF_NODE: Final[dict[int, Any]] = {int(i.node_id): (i.axis, i.motor) for s in REGISTRY if s.kind == "tachometer"
                      for i in s.instances}
AUX_AXIS_OF_NODE: Final[dict[int, Any]] = {int(i.node_id): i.axis for s in REGISTRY if s.kind == "aux_encoder" for i in s.instances}
#: issue 12: axis velocity reader node -> axis
VEL_AXIS_OF_NODE: Final[dict[int, Any]] = {int(i.node_id): i.axis for s in REGISTRY if s.kind == "velocity_reader" for i in s.instances}
_READER_AXIS: Final = {node: axis for axis, node in READER_NODES.items()}
#: EDS (board kind) of each CANopen node: what the host's SDO client reads it with (the USB
#: gateway, the host's own node, has none).
_EDS_OF_NODE: Final[dict[int, Any]] = {int(i.node_id): getattr(s.firmware, "CANOPEN_KIND") for s in REGISTRY if s.canopen for i in s.instances}


def _node_name(node: int) -> str:
    """Log name of a node: the registry's board name; the host node 0x10 (an external host's
    heartbeat seen by ``serve``'s monitor) is ``host``."""
    return NODE_NAMES.get(node, "host" if node == P.NODE_HOST else str(node))


_MODE_CMD: Final = {
    "stop": P.AxisCommand.STOP,
    "slew": P.AxisCommand.SLEW,
    "set": P.AxisCommand.SET,
    "guide": P.AxisCommand.GUIDE,
    "fine": P.AxisCommand.FINE,
    "track": P.AxisCommand.TRACK,
    "velocity": P.AxisCommand.VELOCITY,
    "open_loop": P.AxisCommand.OPEN_LOOP,
}


@dataclass
class AxisState:
    """Latest decoded status of one axis controller, as the host sees it."""

    mode: int = 0
    mode_name: str = "STOP"
    flags: int = 0
    u: float = 0.0                  # control effort U, duty −1..1
    counts: int = 0                 # unwrapped QEI counts (from the 24-bit field)
    rate_arcsec_s: float = 0.0      # from the last tick's QEI delta (coarse: 2.3″/s per count)
    current_a_a: float = 0.0        # motor A current from the shunt ADC [A]
    current_b_a: float = 0.0
    t_us: int = -1
    _raw24: int | None = None


@dataclass
class PositionState:
    pos_counts: int = 0
    flags: int = 0
    crc_errors: int = 0
    t_us: int = -1


@dataclass
class FocusState:
    pos_halfsteps: int = 0
    lvdt_adc: int = 0
    enc_counts: int = 0             # motor encoder, low 16 bits (FOCUS_STATUS b6–7)
    flags: int = 0
    t_us: int = -1


# -- issue 12, room nodes: what the host decodes from the display, dome and weather station
@dataclass
class WeatherState:
    flags: int = 0
    temperature_c: float = 0.0
    humidity_pct: float = 0.0
    wind_m_s: float = 0.0
    t_us: int = -1


@dataclass
class DomeState:
    mode: int = 0
    flags: int = 0
    azimuth_deg: float = 0.0
    target_deg: float = 0.0
    t_us: int = -1


@dataclass
class DisplayState:
    flags: int = 0
    frames_received: int = 0
    refreshes: int = 0
    t_us: int = -1


#: WEATHER_STATUS flags that make the host stop and refuse motion.
WEATHER_UNSAFE: Final = int(P.WeatherFlags.HIGH_WIND | P.WeatherFlags.RAIN)
def weather_flag_names(flags: int) -> str:
    """``"high_wind,rain"``, ``"high_wind"``... or ``"none"`` for WEATHER_STATUS flags."""
    names = [str(f.name).lower() for f in P.WeatherFlags if flags & f]
    return ",".join(names) if names else "none"


_DOME_CMD: Final = {"stop": P.DomeCommand.STOP, "follow": P.DomeCommand.FOLLOW, "goto": P.DomeCommand.GOTO,
             "park": P.DomeCommand.PARK}


@dataclass
class TachState:
    """Latest ``TACH_STATUS`` of one motor tachometer (issue 12)."""

    counts: int = 0                 # unwrapped motor encoder count (from the 16-bit field)
    speed_rad_s: float = 0.0        # the board's speed estimate [rad/s]
    window_ticks: int = 0           # 5 ms ticks that estimate averages over
    frames: int = 0
    t_us: int = -1
    _raw16: int | None = None


@dataclass
class AxisVelocityState:
    """Latest ``AXIS_VELOCITY`` of one axis velocity reader (issue 12)."""

    rate_arcsec_s: float = 0.0      # the board's axis rate estimate [arcsec/s]
    window_ticks: int = 0           # 10 ms ticks that estimate averages over
    frames: int = 0
    t_us: int = -1


@dataclass
class AuxState:
    """Latest ``AUX_POSITION`` of one auxiliary encoder, and its difference from the main encoder
    (issue 12, §5.2)."""

    aux_counts: int = 0
    flags: int = 0
    angle_arcsec: float = 0.0       # aux_counts x the board's resolution [arcsec]
    #: aux − main [arcsec], main extrapolated to this frame's time (None: turns unknown or no
    #: valid POSITION yet)
    diff_arcsec: float | None = None
    frames: int = 0
    t_us: int = -1
    # running statistics of diff_arcsec over every frame (the report)
    n: int = 0
    sum: float = 0.0
    sumsq: float = 0.0
    max_abs: float = 0.0


@dataclass
class Health:
    """Result of the power-on health check."""

    ok: bool
    answered: dict[str, int]        # board -> simulated time of its SDO answer [µs]
    missing: list[str]
    latency_us: dict[str, int] = field(default_factory=dict)   # board -> answer − request [µs]


#: SDO upload request of object 0x1000 sub 0 (CiA 301 initiate upload, cs 0x40): the health check.
SDO_UPLOAD_1000: Final = bytes((0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0))
_ARCSEC_PER_POS_COUNT: Final = ARCSEC_PER_REV / P.POS_COUNTS_PER_REV


def _signed_arcsec(pos_counts: int) -> float:
    """A reader's 29-bit position as a signed axis angle [arcsec] (−180° .. 180°)."""
    c = pos_counts - P.POS_COUNTS_PER_REV if pos_counts >= P.POS_COUNTS_PER_REV // 2 else pos_counts
    return c * _ARCSEC_PER_POS_COUNT


@mypyc_attr(allow_interpreted_subclasses=True)
class HostTiming:
    """The host client's constants (class attributes of :class:`HostClient`, which inherits them;
    a subclass may override them, e.g. ``BusMonitor.THROUGH_GATEWAY``). Kept out of the
    dataclass body so that they stay class attributes, not constructor fields."""

    #: The assembly (:func:`host.network.build_network`) gives this host the bus of the USB-HID
    #: gateway (:class:`host.gateway_bus.HidGatewayBus`), as the paper's PC had (§3.4).
    THROUGH_GATEWAY: ClassVar[bool] = True
    BOOT_US: ClassVar[int] = 20_000       #: wait after power-on before the health check [µs] (assumed)
    POWER_ON_US: ClassVar[int] = 100_000  #: time the boards have to answer the health check's SDO [µs] (assumed)
    HEARTBEAT_US: ClassVar[int] = 1_000_000   #: the host's CiA heartbeat period [µs] (its EDS 0x1017, 1000 ms)
    POLL_US: ClassVar[int] = 1_000            #: step while waiting for the health check's answers [µs]
    #: a health-check SDO request not answered within this long is sent again (at most until
    #: ``POWER_ON_US``) [µs] (assumed: a careful SDO client retries; a USB gateway whose CAN
    #: receive buffers overflow when many nodes answer at once drops answers, docs/usb-gateway.md)
    SDO_RETRY_US: ClassVar[int] = 20_000
    #: A board whose heartbeat (1 s period) has not arrived for this long is LOST [µs]: 2.5
    #: periods (assumed; CiA 301 practice is a consumer time of 1.5–3 producer periods).
    HEARTBEAT_TIMEOUT_US: ClassVar[int] = 2_500_000
    HEARTBEAT_CHECK_US: ClassVar[int] = 100_000   #: how often the host checks [µs] (a lost board is logged ≤ 0.1 s late)
    #: No WEATHER_STATUS (1 s period) for this long makes the weather unsafe [µs]: 2.5 periods,
    #: the heartbeat rule (assumed; docs/faults.md "Weather").
    WEATHER_TIMEOUT_US: ClassVar[int] = 2_500_000
    QEI_WRAP: ClassVar[int] = 1 << 24

    #: The auxiliary-vs-main statistics use only frames while the main encoder moves at most this
    #: fast [arcsec/s]: frames carry no sampling time, and a skew of up to one 10 ms period
    #: between the two boards' samples is then at most 1″ (assumed console practice: cross-check
    #: at rest or tracking, not during a slew).
    AUX_COMPARE_MAX_RATE_ARCSEC_S: ClassVar[float] = 100.0


@mypyc_attr(allow_interpreted_subclasses=True)   # compiled (bus/_native.py); BusMonitor subclasses it
@dataclass
class HostClient(HostTiming):
    """Operator client over a python-can bus in simulated time.

    Parameters
    ----------
    bus : can.BusABC
        Any python-can bus (``schmidt-sim``, ``virtual``, ``socketcan``).
    scheduler : Scheduler
        The simulated clock.
    expected_nodes : tuple of int
        Nodes that must answer the power-on health check (default: the CANopen boards of the
        ``basic`` network; :func:`host.network.build_network` passes the scenario network's).
    preset_rates_arcsec_s : dict
        Firmware preset rates keyed by ``(mode name, axis)``, to report setpoints.
    open_loop_duty : callable(rate_arcsec_s, axis) -> float
        The operator's duty-speed map for open-loop runs.
    adc_to_current_a : callable(counts) -> float
        Shunt ADC counts to motor current [A].
    arcsec_per_count : dict
        ``{"ra": ..., "dec": ...}``: incremental-encoder resolution at the axis [arcsec/count]
        the host scales QEI counts with; the assembly sets it from the axis boards that run.
    advance : callable(t_us), optional
        How :meth:`power_on` advances simulated time; default ``scheduler.run_until``. On a real
        bus the runner passes its real-time pacer here, so the boot wait and the PING's answer
        window are wall-clock time (a node outside this process answers in wall-clock time).
    """

    bus: Any                     # a can.BusABC (duck-typed: any python-can bus)
    scheduler: Scheduler
    expected_nodes: tuple = network_nodes("basic")
    preset_rates_arcsec_s: Mapping = field(default_factory=dict)
    open_loop_duty: Callable[[float, str], float] | None = None
    adc_to_current_a: Callable[[int], float] = lambda c: c * (5.0 / 1023) / 0.1
    logs: Any = None
    advance: Callable[[int], None] | None = None
    arcsec_per_count: Mapping = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.axes = {"ra": AxisState(), "dec": AxisState()}
        self.setpoints = {"ra": 0.0, "dec": 0.0}   # the rate each axis was last commanded [arcsec/s]
        self.positions = {"ra": PositionState(), "dec": PositionState()}
        self.focus = FocusState()
        self.weather = WeatherState()          # issue 12, room nodes
        self.dome = DomeState()
        self.display = DisplayState()
        self.weather_unsafe = False            # HIGH_WIND, RAIN or a silent station, not yet cleared
        self.weather_silent = False            # no WEATHER_STATUS for WEATHER_TIMEOUT_US
        self._watch_since_us = 0               # when the heartbeat watch started [µs]
        self.weather_stops = 0                 # times the weather stopped the telescope
        self.refused_commands = 0              # commands the host refused (weather)
        # issue 12: motor tachometers and auxiliary encoders (maintenance consoles, §5.2)
        self.tachs: dict[int, TachState] = {}
        self.axis_velocity: dict[str, AxisVelocityState] = {}   # axis -> its velocity reader's last frame
        self.aux: dict[str, AuxState] = {}
        self.tach_counts_per_rev: dict[int, int] = {}
        self.aux_arcsec_per_count: dict[int, float] = {}
        self._main_prev: dict[str, tuple[int, int, float]] = {}    # axis -> (t_us, flags, arcsec) of the POSITION before
        self.peak_current_a: dict[tuple[str, str], float] = {}   # (axis, motor) -> peak from AXIS_AUX
        self.heartbeats: dict[int, tuple[int, int]] = {}   # node -> (t_us, NMT state)
        self.sdo_answers: dict[int, int] = {}   # node -> time of its last SDO response [µs]
        self.emcy_active: dict[int, dict[int, int]] = {}   # node -> {error code: detail}
        self.emcy_frames = 0
        self._heartbeat_event: Any = None
        #: called with (can_id, data, t_us) for SDO responses, EMCY and heartbeats (a canopen
        #: master network's ``notify``, host/canopen_master.py)
        self.canopen_notify: Callable | None = None
        self.canopen: Any = None                  # host.canopen_master.HostCanopenNetwork, at power-on
        self.identities: dict[str, dict] = {}     # board -> identity read by SDO at power-on
        self.parameters: dict[str, dict] = {}     # board -> parameters read back by SDO
        self.frames_received = 0
        self.malformed_frames = 0
        self._errors: list[str] = []
        self._last_state: dict[int, int] = {}
        self._last_mode: dict[str, int] = {}
        self.lost: set[int] = set()          # nodes whose heartbeat stopped (the report's LOST)
        self._watch_event: Any = None
        # frame type -> handler, built once (not looked up by name for every frame)
        self._handlers = {
            P.AxisStatus: self._on_AxisStatus, P.AxisAux: self._on_AxisAux, P.Position: self._on_Position,
            P.FocusStatus: self._on_FocusStatus, P.Heartbeat: self._on_Heartbeat, P.Emcy: self._on_Emcy,
            P.Limit: self._on_Limit,
            P.WeatherStatus: self._on_WeatherStatus, P.DomeStatus: self._on_DomeStatus,
            P.DisplayStatus: self._on_DisplayStatus, P.TachStatus: self._on_TachStatus, P.AuxPosition: self._on_AuxPosition,
            P.AxisVelocity: self._on_AxisVelocity,
        }
        if hasattr(self.bus, "set_rx_callback"):
            self.bus.set_rx_callback(self.poll)
            self._poll_event = None
        else:  # a plain python-can bus: poll like a 1 ms USB-HID interrupt endpoint
            self._poll_event = self.scheduler.call_every(1_000, lambda now: self.poll(), priority=PRIO_HOST,
                                                         owner="host-poll")

    # -- receive -------------------------------------------------------------------------------
    def poll(self) -> None:
        """Drain the bus and decode every frame (called from the rx interrupt or a 1 ms poll)."""
        drain = getattr(self.bus, "drain_frames", None)
        if drain is not None and type(self)._handle is HostClient._handle:
            # the gateway's bus hands out (id, data, timestamp) tuples: no can.Message per frame
            # (a subclass that observes the Message, BusMonitor, keeps the recv path)
            # self._handle_frame called directly: compiled, a native call (a bound-method alias
            # would go through Python's call protocol and argument parsing for every frame)
            while True:
                frames: list = drain()
                if not frames:
                    return
                f: tuple
                for f in frames:         # typed: the items are read natively (session 17)
                    self.frames_received += 1
                    self._handle_frame(f[0], f[1])
        while True:
            msg = self.bus.recv(0.0)
            if msg is None:
                return
            self.frames_received += 1
            self._handle(msg)

    def _handle(self, msg: can.Message) -> None:
        self._handle_frame(msg.arbitration_id, bytes(msg.data))

    def _handle_frame(self, cob: int, data: bytes) -> None:
        now = self.scheduler.now_us
        if P.FC_SDO_TX < cob < P.FC_SDO_RX:          # an SDO response (not in the frame table)
            self.sdo_answers[cob - P.FC_SDO_TX] = now
            if self.canopen_notify is not None:
                self.canopen_notify(cob, data, now)
            return
        if self.canopen_notify is not None and (cob >> 7) in (0x1, 0xE):   # EMCY, heartbeat
            self.canopen_notify(cob, data, now)
        try:
            decoder = _DECODERS[cob] if 0 <= cob <= 0x7FF else None   # P.decode, inlined
            frame = decoder(data) if decoder is not None else P.decode(cob, data)
        except MalformedFrame as exc:
            self.malformed_frames += 1
            self._error(now, f"0x{cob:03X}", "malformed-frame", str(exc))
            return
        handler = self._handlers.get(type(frame))
        if handler is not None:  # frames the host does not consume (commands) have none
            handler(cob, frame, now)

    def _on_AxisStatus(self, cob_id: int, f, now: int) -> None:
        node = _node_of(cob_id)
        axis = _AXIS_OF_NODE[node]
        st = self.axes[axis]
        raw = f.qei_counts
        wrap = self.QEI_WRAP           # once: a class attribute through ``self`` is a generic lookup
        if st._raw24 is None:
            st.counts = raw if raw < wrap // 2 else raw - wrap
        else:
            d = (raw - st._raw24) % wrap
            if d >= wrap // 2:
                d -= wrap
            st.counts += d
        st._raw24 = raw
        st.u = q15_to_duty(f.u_q15)
        st.flags = f.flags
        st.t_us = now
        if st.mode != f.mode or axis not in self._last_mode:
            name = P.AxisMode(f.mode).name
            if self.logs:
                self.logs.status(now, node, NODE_NAMES[node], "mode", name)
            st.mode_name = name
        st.mode = f.mode
        self._last_mode[axis] = f.mode

    def _on_AxisAux(self, cob_id: int, f, now: int) -> None:
        axis = _AXIS_OF_NODE[_node_of(cob_id)]
        st = self.axes[axis]
        st.current_a_a = self.adc_to_current_a(f.adc_a)
        st.current_b_a = self.adc_to_current_a(f.adc_b)
        pk = self.peak_current_a
        if st.current_a_a > pk.get((axis, "a"), 0.0):
            pk[(axis, "a")] = st.current_a_a
        if st.current_b_a > pk.get((axis, "b"), 0.0):
            pk[(axis, "b")] = st.current_b_a
        st.rate_arcsec_s = f.qei_delta * self.arcsec_per_count[axis] / (TICK_US * 1e-6)

    def _on_Position(self, cob_id: int, f, now: int) -> None:
        node = _node_of(cob_id)
        ps = self.positions["ra" if node == P.NODE_RA_READER else "dec"]
        if ps.t_us >= 0 and ps.t_us != now:
            self._main_prev[_READER_AXIS[node]] = (ps.t_us, ps.flags, _signed_arcsec(ps.pos_counts))
        if f.crc_errors != ps.crc_errors and ps.t_us >= 0:
            self._error(now, NODE_NAMES[node], "endat-crc", f"crc_errors {ps.crc_errors} -> {f.crc_errors}")
        ps.pos_counts, ps.flags, ps.crc_errors, ps.t_us = f.pos_counts, f.flags, f.crc_errors, now

    # -- issue 12: tachometers and auxiliary encoders -----------------------------------------
    def configure_maintenance(self, tach_counts_per_rev: dict, aux_arcsec_per_count: dict) -> None:
        """Resolutions of the tachometers and auxiliary encoders on the network (node -> counts
        per motor revolution / arcsec per count at the axis), read from the boards that run
        (:func:`host.network.build_network`). Frames of other nodes are decoded but not scaled."""
        self.tach_counts_per_rev = dict(tach_counts_per_rev)
        self.aux_arcsec_per_count = dict(aux_arcsec_per_count)
        self.tachs = {n: TachState() for n in self.tach_counts_per_rev}
        self.aux = {AUX_AXIS_OF_NODE[n]: AuxState() for n in self.aux_arcsec_per_count}

    def _on_TachStatus(self, cob_id: int, f, now: int) -> None:
        node = _node_of(cob_id)
        st = self.tachs.get(node)
        if st is None:
            st = self.tachs[node] = TachState()
        raw = f.counts
        if st._raw16 is None:
            st.counts = raw if raw < 0x8000 else raw - 0x10000
        else:
            d = (raw - st._raw16) & 0xFFFF
            st.counts += d - 0x10000 if d >= 0x8000 else d
        st._raw16 = raw
        st.speed_rad_s = f.speed_urad_s * 1e-6
        st.window_ticks = f.window_ticks
        st.frames += 1
        st.t_us = now

    def _on_AxisVelocity(self, cob_id: int, f, now: int) -> None:
        axis = VEL_AXIS_OF_NODE[_node_of(cob_id)]
        st = self.axis_velocity.get(axis)
        if st is None:
            st = self.axis_velocity[axis] = AxisVelocityState()
        st.rate_arcsec_s, st.window_ticks, st.t_us = f.rate_marcsec_s * 1e-3, f.window_ticks, now
        st.frames += 1

    def _on_AuxPosition(self, cob_id: int, f, now: int) -> None:
        node = _node_of(cob_id)
        axis = AUX_AXIS_OF_NODE[node]
        st = self.aux.get(axis)
        if st is None:
            st = self.aux[axis] = AuxState()
        st.aux_counts, st.flags, st.t_us = f.aux_counts, f.flags, now
        st.frames += 1
        res = self.aux_arcsec_per_count.get(node)
        st.diff_arcsec = None
        if res is None:
            return
        st.angle_arcsec = f.aux_counts * res
        if f.flags & _AUX_TURNS_UNKNOWN:
            return
        main = self.main_arcsec(axis, now)
        if main is None:
            return
        d = st.angle_arcsec - main[0]
        st.diff_arcsec = d
        if main[1] is None or abs(main[1]) > self.AUX_COMPARE_MAX_RATE_ARCSEC_S:
            return                     # moving fast: the frames' sampling skew would dominate
        st.n += 1
        st.sum += d
        st.sumsq += d * d
        if abs(d) > st.max_abs:
            st.max_abs = abs(d)

    def main_arcsec(self, axis: str, t_us: int) -> tuple[float, float | None] | None:
        """The main (EnDat) encoder's last valid signed axis angle [arcsec] and its rate [arcsec/s]
        from its last two ``POSITION`` frames (None if unknown); None without a valid POSITION
        (flags CRC_ERROR or INVALID clear) in the 100 ms before ``t_us``. Not extrapolated: the
        boards sample on their own 10 ms ticks and the frames carry no sampling time."""
        ps = self.positions[axis]
        bad = _POSITION_BAD
        if ps.t_us < 0 or ps.flags & bad or t_us - ps.t_us > 100_000:
            return None
        a = _signed_arcsec(ps.pos_counts)
        prev = self._main_prev.get(axis)
        rate = None
        if prev is not None and not prev[1] & bad and 0 < ps.t_us - prev[0] <= 100_000:
            rate = (a - prev[2]) * 1e6 / (ps.t_us - prev[0])
        return a, rate

    def _on_FocusStatus(self, cob_id: int, f, now: int) -> None:
        self.focus.pos_halfsteps, self.focus.lvdt_adc, self.focus.flags, self.focus.t_us = (
            f.pos_halfsteps, f.lvdt_adc, f.flags, now)
        self.focus.enc_counts = f.enc_counts

    def _on_Heartbeat(self, cob_id: int, f, now: int) -> None:
        node = _node_of(cob_id)
        self.heartbeats[node] = (now, f.state)
        if node in self.lost:
            self.lost.discard(node)
            self._error(now, _node_name(node), "heartbeat-back", "the board answers again")
        if self._last_state.get(node) != f.state:
            if self.logs:
                self.logs.status(now, node, _node_name(node), "state",
                                 P.NodeState(f.state).name)
            self._last_state[node] = f.state
        if (f.state == P.NodeState.BOOT and self._watch_event is not None
                and node in self.expected_nodes):
            # a board that rebooted after the power-on (watchdog reset, power back) announces
            # itself with its boot-up message and waits in PRE-OPERATIONAL: as NMT master the
            # host starts it again (CiA 302 boot-up handling) and says so
            self._error(now, _node_name(node), "rebooted", "boot-up message after power-on; NMT start sent")
            self.send_nmt(P.NmtCommand.START, node)

    def watch_heartbeats(self) -> None:
        """Start checking every expected board's heartbeat (after the health check): a board
        silent for :attr:`HEARTBEAT_TIMEOUT_US` is logged at once in ``errors.log`` as
        ``heartbeat-lost`` and listed in :attr:`lost` (the report shows it LOST)."""
        if self._watch_event is None:
            self._watch_since_us = self.scheduler.now_us
            self._watch_event = self.scheduler.call_every(self.HEARTBEAT_CHECK_US, self._check_heartbeats,
                                                          priority=PRIO_HOST, owner="host-heartbeat-watch")

    def _check_heartbeats(self, now: int) -> None:
        for node in self.expected_nodes:
            seen = self.heartbeats.get(node)
            if node not in self.lost and seen is not None and now - seen[0] > self.HEARTBEAT_TIMEOUT_US:
                self.lost.add(node)
                self._error(now, _node_name(node), "heartbeat-lost",
                            f"no heartbeat for {(now - seen[0]) / 1e6:.2f} s (timeout "
                            f"{self.HEARTBEAT_TIMEOUT_US / 1e6:.1f} s)")
        self._check_weather_silence(now)

    def _on_Emcy(self, cob_id: int, f, now: int) -> None:
        node = _node_of(cob_id)
        self.emcy_frames += 1
        active = self.emcy_active.setdefault(node, {})
        source = _node_name(node)
        if f.error_code == 0:          # error reset: detail = the cleared error code
            active.pop(f.detail, None)
            self._error(now, source, "cleared", f"{P.FaultCode(f.fault_code).name.lower()} "
                        f"emcy=0x{f.detail:04X} register=0x{f.error_register:02X}")
            return
        active[f.error_code] = f.detail
        self._error(now, source, P.FaultCode(f.fault_code).name.lower(),
                    f"emcy=0x{f.error_code:04X} register=0x{f.error_register:02X} detail={f.detail} "
                    f"count={f.count}")

    def _on_Limit(self, cob_id: int, f, now: int) -> None:
        node = _node_of(cob_id)
        if self.logs:
            self.logs.status(now, node, _node_name(node), "limit", f"flags=0x{f.flags:02X} pos={f.pos_counts}")

    # -- issue 12, room nodes ---------------------------------------------------------------------
    def _on_WeatherStatus(self, cob_id: int, f, now: int) -> None:
        w = self.weather
        changed = f.flags != w.flags or w.t_us < 0
        w.flags, w.temperature_c, w.humidity_pct, w.wind_m_s, w.t_us = (
            f.flags, f.temperature_cdegc / 100.0, f.humidity_cpct / 100.0, f.wind_cm_s / 100.0, now)
        desc = (f"flags={weather_flag_names(f.flags)} wind={w.wind_m_s:.2f}m/s humidity={w.humidity_pct:.2f}% "
                f"temperature={w.temperature_c:.2f}C")
        if changed and self.logs:
            self.logs.status(now, P.NodeId.WEATHER, NODE_NAMES.get(P.NodeId.WEATHER, "weather"), "weather", desc)
        unsafe = bool(f.flags & WEATHER_UNSAFE)
        self.weather_silent = False            # the station speaks again: only its flags count
        if unsafe and not self.weather_unsafe:
            self._weather_turns_unsafe(now, "weather-unsafe", desc)
        elif not unsafe and self.weather_unsafe:
            self.weather_unsafe = False
            self._error(now, "host", "weather-clear", desc + "; motion commands accepted again")

    def _weather_turns_unsafe(self, now: int, error: str, desc: str) -> None:
        """Stop everything and park the dome: bad weather, or no weather data (fail-safe)."""
        self.weather_unsafe = True
        self.weather_stops += 1
        self._error(now, "host", error, desc + "; stopping the axes, parking the dome")
        self.stop_all()
        for axis in self.setpoints:
            self.setpoints[axis] = 0.0
        if int(P.NodeId.DOME) in self.expected_nodes:
            self._send(P.dome_command_cob_id(), P.encode_dome_command(P.DomeCommand.PARK), "dome", "PARK",
                       "weather")

    def _check_weather_silence(self, now: int) -> None:
        """No ``WEATHER_STATUS`` for :attr:`WEATHER_TIMEOUT_US` on a network with the station: the
        weather is unknown, and unknown weather is treated as unsafe (fail-safe, as an observatory
        safety monitor does: ASCOM ``ISafetyMonitor.IsSafe`` is false without data). It catches a
        lost station, a stopped one (NMT stop: heartbeat on, PDOs off) and a dead sensor loop."""
        if int(P.NodeId.WEATHER) not in self.expected_nodes or self.weather_silent:
            return
        since = self.weather.t_us if self.weather.t_us >= 0 else self._watch_since_us
        if now - since > self.WEATHER_TIMEOUT_US:
            self.weather_silent = True
            desc = (f"no WEATHER_STATUS for {(now - since) / 1e6:.2f} s (timeout "
                    f"{self.WEATHER_TIMEOUT_US / 1e6:.1f} s): weather unknown")
            if self.weather_unsafe:     # already stopped by its flags: say so, do not stop twice
                self._error(now, "host", "weather-silent", desc)
            else:
                self._weather_turns_unsafe(now, "weather-silent", desc)

    def _on_DomeStatus(self, cob_id: int, f, now: int) -> None:
        d = self.dome
        if (f.mode, f.flags & int(P.DomeFlags.PARKED)) != (d.mode, d.flags & int(P.DomeFlags.PARKED)) and self.logs:
            self.logs.status(now, P.NodeId.DOME, "dome", "dome",
                             f"mode={P.DomeMode(f.mode).name} parked={bool(f.flags & P.DomeFlags.PARKED)} "
                             f"azimuth={f.azimuth_cdeg / 100:.2f}")
        d.mode, d.flags, d.azimuth_deg, d.target_deg, d.t_us = (
            int(f.mode), f.flags, f.azimuth_cdeg / 100.0, f.target_cdeg / 100.0, now)

    def _on_DisplayStatus(self, cob_id: int, f, now: int) -> None:
        d = self.display
        d.flags, d.frames_received, d.refreshes, d.t_us = f.flags, f.frames_received, f.refreshes, now

    def _refuse(self, target: str, what: str) -> None:
        """Refuse a motion command while the weather is unsafe (commands.log and errors.log)."""
        now = self.scheduler.now_us
        self.refused_commands += 1
        why = f"weather unsafe ({weather_flag_names(self.weather.flags)})"
        if self.logs:
            self.logs.command(now, target, "REFUSED", f"{what}: {why}")
        self._error(now, "host", "command-refused", f"{target} {what}: {why}")

    def command_dome(self, what: str, azimuth_deg: float | None = None) -> bool:
        """Send a ``DOME_COMMAND``: ``"follow"``, ``"goto"`` (``azimuth_deg``), ``"park"`` or
        ``"stop"``. While the weather is unsafe, ``follow`` and ``goto`` are refused (logged).

        Returns
        -------
        bool
            True if sent.

        Raises
        ------
        ValueError
            Unknown command, or ``goto`` without an azimuth.
        """
        if what not in _DOME_CMD:
            raise ValueError(f"unknown dome command {what!r}; expected one of {sorted(_DOME_CMD)}")
        if what in ("follow", "goto") and self.weather_unsafe:
            self._refuse("dome", what.upper())
            return False
        value = 0
        if what == "goto":
            if azimuth_deg is None:
                raise ValueError("dome goto needs azimuth_deg")
            value = int(round(azimuth_deg * 100))
        self._send(P.dome_command_cob_id(), P.encode_dome_command(_DOME_CMD[what], value), "dome",
                   what.upper(), f"value={value}")
        return True

    def _error(self, now: int, source: str, error: str, detail: str) -> None:
        self._errors.append(f"{now / 1e6:.6f} s {source}: {error} {detail}")
        if self.logs:
            self.logs.error(now, source, error, detail)

    def error_lines(self) -> list[str]:
        """Errors seen by the host, oldest first (also in ``errors.log``)."""
        return list(self._errors)

    # -- send ----------------------------------------------------------------------------------
    def _send(self, cob_id: int, data: bytes, target: str, what: str, detail: str = "") -> None:
        self.bus.send(can.Message(arbitration_id=cob_id, data=data, is_extended_id=False, dlc=8))
        if self.logs:
            self.logs.command(self.scheduler.now_us, target, what, detail)

    def send_nmt(self, cmd: int, target_node: int = 0) -> None:
        """Send an NMT command (``bus.protocol.NmtCommand``; target 0 = all nodes)."""
        self.bus.send(can.Message(arbitration_id=P.nmt_cob_id(),
                                  data=P.encode_nmt(cmd, target_node), is_extended_id=False))
        if self.logs:
            target = "all" if target_node == 0 else NODE_NAMES.get(target_node, f"node-{target_node}")
            self.logs.command(self.scheduler.now_us, target, f"NMT {P.NmtCommand(cmd).name}", "")

    def start_heartbeat(self) -> None:
        """Produce the host's CiA heartbeat (0x710, state OPERATIONAL) every :attr:`HEARTBEAT_US`,
        the first one now."""
        if self._heartbeat_event is not None:
            return
        cob, data = P.heartbeat_cob_id(P.NODE_HOST), P.encode_heartbeat(P.NodeState.OPERATIONAL)

        def beat(now_us: int) -> None:
            self.bus.send(can.Message(arbitration_id=cob, data=data, is_extended_id=False))

        self._heartbeat_event = self.scheduler.call_every(
            self.HEARTBEAT_US, beat, start_us=self.scheduler.now_us, priority=PRIO_HOST,
            owner="host-heartbeat")

    def read_boards(self, nodes) -> None:
        """Read identity (0x1018, 0x1008, 0x100A) and parameters (the EDS's manufacturer objects
        with a range) of each node by SDO with canopen's ``RemoteNode``
        (:mod:`host.canopen_master`); kept in :attr:`identities` / :attr:`parameters` by board
        name for the report. A node that stops answering is logged as an error."""
        from host.canopen_master import (HostCanopenNetwork, SdoAbortedError,
                                         SdoCommunicationError, read_identity, read_parameters)
        if self.canopen is None:
            self.canopen = HostCanopenNetwork(self.bus, lambda: self.scheduler.now_us,
                                              self.advance or self.scheduler.run_until)
            self.canopen_notify = self.canopen.notify
        for n in nodes:
            name = NODE_NAMES[n]
            node = self.canopen.nodes.get(n) or self.canopen.add_board(_EDS_OF_NODE[n], n)
            try:
                self.identities[name] = read_identity(node)
                self.parameters[name] = read_parameters(node)
            except (SdoAbortedError, SdoCommunicationError) as exc:
                self._error(self.scheduler.now_us, name, "sdo", f"identity/parameters: {exc}")
        if self.logs:
            self.logs.status(self.scheduler.now_us, P.NODE_HOST, "host", "identity",
                             " ".join(f"{k}={v['device_name']!r}/{v['serial_number']:#x}"
                                      for k, v in self.identities.items()))

    def power_on(self) -> Health:
        """Let the boards boot (``BOOT_US``), read object 0x1000 of every expected node by SDO
        and wait (at most ``POWER_ON_US``) for the answers; read identity and parameters of every
        node that answered (:meth:`read_boards`); at ``POWER_ON_US`` after the check (later only
        if the reads took longer) NMT start (all nodes) and the host's own heartbeat.

        Returns
        -------
        Health
            ``ok`` is false and ``missing`` names each board that did not answer in time.
        """
        run_until = self.advance or self.scheduler.run_until
        # the boards boot into PRE-OPERATIONAL (boot-up message); SDO works there
        run_until(self.scheduler.now_us + self.BOOT_US)
        t0 = self.scheduler.now_us

        def ask(nodes) -> None:
            for n in nodes:
                self.bus.send(can.Message(arbitration_id=P.sdo_request_cob_id(n), data=SDO_UPLOAD_1000,
                                          is_extended_id=False))

        ask(self.expected_nodes)
        if self.logs:
            self.logs.command(t0, "all", "SDO upload 0x1000", "power-on health check")
        asked = t0
        while (self.scheduler.now_us < t0 + self.POWER_ON_US
               and any(self.sdo_answers.get(n, -1) < t0 for n in self.expected_nodes)):
            if self.scheduler.now_us - asked >= self.SDO_RETRY_US:
                again = [n for n in self.expected_nodes if self.sdo_answers.get(n, -1) < t0]
                ask(again)
                asked = self.scheduler.now_us
                if self.logs:
                    self.logs.command(asked, "host", "SDO upload 0x1000",
                                      "health check retry: " + ",".join(_node_name(n) for n in again))
            run_until(min(self.scheduler.now_us + self.POLL_US, t0 + self.POWER_ON_US))
        # the health check's answers (before the identity reads add answers of their own)
        answered = {NODE_NAMES[n]: self.sdo_answers[n] for n in self.expected_nodes
                    if self.sdo_answers.get(n, -1) >= t0}
        self.read_boards([n for n in self.expected_nodes if self.sdo_answers.get(n, -1) >= t0])
        if self.scheduler.now_us < t0 + self.POWER_ON_US:
            run_until(t0 + self.POWER_ON_US)
        missing = [NODE_NAMES[n] for n in self.expected_nodes if NODE_NAMES[n] not in answered]
        for name in missing:
            self._error(self.scheduler.now_us, name, "no-answer",
                        f"no SDO answer within {self.POWER_ON_US // 1000} ms")
        if self.logs:
            self.logs.status(self.scheduler.now_us, P.NODE_HOST, "host", "health-check",
                             "ok" if not missing else "missing " + ",".join(missing))
        self.send_nmt(P.NmtCommand.START)
        self.start_heartbeat()
        self.watch_heartbeats()
        return Health(ok=not missing, answered=answered, missing=missing,
                      latency_us={k: v - t0 for k, v in answered.items()})

    def command_axis(self, axis: str, mode: str, direction: int = 1, rate_arcsec_s: float | None = None) -> float:
        """Send an ``AXIS_COMMAND``; return the signed setpoint rate [arcsec/s] it means.

        While the weather is unsafe (:attr:`weather_unsafe`) every mode but ``stop`` is refused:
        nothing is sent, the refusal is logged and 0.0 returned.

        Parameters
        ----------
        axis : {"ra", "dec"}
        mode : str
            One of ``host.scenario.MODES``.
        direction : {1, -1}
        rate_arcsec_s : float, optional
            Required for ``velocity`` and ``open_loop``.

        Raises
        ------
        ValueError
            Unknown axis or mode, or a missing rate.
        """
        if axis not in AXIS_NODES:
            raise ValueError(f"unknown axis {axis!r}; expected 'ra' or 'dec'")
        if mode not in _MODE_CMD:
            raise ValueError(f"unknown mode {mode!r}; expected one of {sorted(_MODE_CMD)}")
        if self.weather_unsafe and mode != "stop":
            self._refuse(NODE_NAMES[AXIS_NODES[axis]], mode.upper())
            self.setpoints[axis] = 0.0
            return 0.0
        node = AXIS_NODES[axis]
        cmd = _MODE_CMD[mode]
        value = 0
        if mode == "velocity":
            if rate_arcsec_s is None:
                raise ValueError("velocity mode needs rate_arcsec_s")
            value = int(round(rate_arcsec_s * 1000))
            sp = direction * rate_arcsec_s
        elif mode == "open_loop":
            if rate_arcsec_s is None or self.open_loop_duty is None:
                raise ValueError("open_loop needs rate_arcsec_s and an open-loop duty map")
            duty = self.open_loop_duty(rate_arcsec_s, axis)
            value = duty_to_q15(max(0.0, min(1.0, duty)))
            sp = direction * rate_arcsec_s
        elif mode == "stop":
            sp = 0.0
        else:
            sp = direction * self.preset_rates_arcsec_s[(mode, axis)]
        self._send(P.axis_command_cob_id(node), P.encode_axis_command(cmd, direction, value),
                   NODE_NAMES[node], mode.upper(), f"direction={direction:+d} value={value}")
        self.setpoints[axis] = float(sp)
        return float(sp)

    def command_focus_move_to(self, halfsteps: int) -> None:
        """Send ``FOCUS_COMMAND MOVE_TO`` (absolute position in half-steps)."""
        self._send(P.focus_command_cob_id(), P.encode_focus_command(P.FocusCommand.MOVE_TO, int(halfsteps)),
                   "focus", "MOVE_TO", f"halfsteps={halfsteps}")

    def send_raw(self, cob_id: int, data: bytes, target: str) -> None:
        """Send an arbitrary frame (fault injection: malformed frames)."""
        self._send(cob_id, data, target, "RAW", data.hex())

    def stop_all(self, target_node: int = 0) -> None:
        """Send ``STOP_ALL`` (0x190; target 0 = every board with motion)."""
        self._send(P.stop_all_cob_id(), P.encode_stop_all(target_node=target_node), "all", "STOP_ALL")

    def close(self) -> None:
        if self._poll_event is not None:
            self.scheduler.cancel(self._poll_event)
        if self._heartbeat_event is not None:
            self.scheduler.cancel(self._heartbeat_event)
            self._heartbeat_event = None

