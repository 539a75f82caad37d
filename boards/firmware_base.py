"""What every schmidt-fil board's firmware shares: CAN node, heartbeat, reset, malformed frames.

A board is read-only configuration (device type, node id, name, periods) plus mutable runtime
state that :meth:`Board.reset` restores to its power-on values. Firmware touches hardware only
through its peripherals (:mod:`boards.peripherals`).

Execution model (simulated time, :class:`bus.scheduler.Scheduler`):

* timer ISRs at ``PRIO_ISR`` — sample, compute, write outputs, set flags; nothing else;
* the CAN receive interrupt (``SimBus`` rx callback, ``PRIO_CAN``) — the receive handler
  decodes and applies commands (short: parse, set a few variables);
* a background loop at ``PRIO_BACKGROUND`` (same period and phase as the board's main timer, so
  it runs right after the ISR at the same instant) — transmits the periodic frames queued by the
  ISR, writes a finished RS232 telemetry packet and, on a bus without a receive interrupt, polls
  the CAN controller.

RS232 telemetry (paper §3.4, layout :mod:`bus.telemetry`): a board built with a
``serial_port`` (any object with the pyserial ``write()`` API) has a :class:`Uart`; its firmware
calls :meth:`Board.telemetry_sample` every 10 ms from an ISR or loop it already runs (no extra
timer), and every 25th sample the background loop encodes one packet and writes it — one write
per 250 ms, no per-sample or per-byte events. Without a port nothing is sampled.

CANopen (CiA 301, docs/canopen.md): every board owns a
:class:`boards.services.CanopenDevice` (object dictionary from its EDS, SDO server, NMT slave,
heartbeat producer at 0x1017, heartbeat consumer 0x1016, EMCY). The receive interrupt feeds the
device first (NMT, SDO, consumed heartbeats); process data (commands, LIMIT, STOP_ALL) is acted
on only in NMT OPERATIONAL, and the periodic frames go out through the device's PDO gate (a
node that is not OPERATIONAL sends none). The firmware keeps running its ISRs in every NMT state:
NMT gates communication, not control. ``send_fault`` sends an EMCY; a *condition* (over-current,
CRC, limit stop...) is cleared with :meth:`Board.clear_fault` (EMCY error reset).

Robustness contract (architecture.md, STYLE.md §8): a frame that cannot be decoded (wrong DLC,
wrong device-type byte, unknown command or enum, remote or extended frame on an accepted id) is
counted in ``malformed_frames`` and answered with an EMCY MALFORMED_FRAME (detail = the frame's
identifier) — at most a burst of 4, then 10 per second (a flood of bad frames must not fill the
board's own transmit queue); the board never raises into the bus for it. Any *other* exception is a bug in the
emulator and propagates (the scheduler stops the run and names the board).

Reset semantics: :meth:`Board.reset` is a processor reset. RAM state, counters (malformed
frames, CRC errors, CAN overflow) and outputs return to power-on values; ``reset_cause`` and
``reset_count`` survive (they model the RCON register and a persistent boot counter). If the
board was running, it boots again (schedules its ISRs, sends the CANopen boot-up message and
enters PRE-OPERATIONAL). An NMT reset node is ``reset("software")``.
"""

from __future__ import annotations

from typing import Any, ClassVar, Dict, Final, List, Optional

import can
from mypy_extensions import mypyc_attr

from bus import protocol as proto
from bus import telemetry as tlm
from boards.peripherals import CanController, Timer, Uart
from boards.services import Application, CanopenDevice, ObjectRefused
from boards.services.pdo import PdoGate
from bus.eds.objects import EMCY_OF_FAULT
from bus.errors import MalformedFrame
from bus.scheduler import PRIO_BACKGROUND, Scheduler

__all__ = ["Firmware", "Board", "RESET_CAUSES", "STATE_BOOT", "STATE_OPERATIONAL", "STATE_FAULT",
           "STATE_STOPPED", "FAULT_MALFORMED", "FAULT_CRC", "FAULT_OVERCURRENT",
           "FAULT_LIMIT_STOP", "FAULT_WATCHDOG", "FAULT_STEP_LOSS", "FAULT_REFUSED",
           "FAULT_BRAKE_CUT", "FAULT_READER_LOST", "FAULT_HOST_TIMEOUT", "FAULT_CLEARED", "FAULT_OVERSPEED"]

RESET_CAUSES: Final[Dict[str, int]] = {"power_on": 0, "watchdog": 1, "software": 2}
_CAUSE_NAMES: Final = {v: k for k, v in RESET_CAUSES.items()}

STATE_BOOT, STATE_OPERATIONAL, STATE_FAULT, STATE_STOPPED = 0, 1, 2, 3
#: Longest background-loop period of a board whose CAN controller is polled (no receive
#: interrupt on the bus), µs: the axis controllers' 5 ms tick (§3.3), short enough for the MCP2515's
#: two receive buffers at the bus loads of the paper's networks (assumed; see Board.__init__).
POLL_PERIOD_US: Final = 5_000

FAULT_MALFORMED, FAULT_CRC, FAULT_OVERCURRENT, FAULT_LIMIT_STOP, FAULT_WATCHDOG = 1, 2, 3, 4, 5
FAULT_STEP_LOSS: Final = int(proto.FaultCode.STEP_LOSS)
FAULT_REFUSED: Final = int(proto.FaultCode.COMMAND_REFUSED)
FAULT_BRAKE_CUT: Final = int(proto.FaultCode.BRAKE_CUT)
FAULT_READER_LOST: Final = int(proto.FaultCode.READER_LOST)
FAULT_HOST_TIMEOUT: Final = int(proto.FaultCode.HOST_TIMEOUT)
FAULT_CLEARED: Final = int(proto.FaultCode.FAULT_CLEARED)
FAULT_OVERSPEED: Final = int(proto.FaultCode.OVERSPEED)
#: FAULT MALFORMED_FRAME rate limit (token bucket): a burst of this many, then this many per
#: second (assumed; found by the 10⁶-frame fuzz: one FAULT per malformed frame let a flood of
#: bad frames fill a board's own TX FIFO, so its LIMIT frames waited and DEC ran 0.36° past
#: its limit). Every malformed frame is still counted in ``malformed_frames``.
MALFORMED_FAULT_BURST: Final = 4
MALFORMED_FAULT_RATE_HZ: Final = 10
#: A fault condition (:meth:`Board.fault_condition`) is cleared after being absent this long, µs
#: (assumed: 1 s, see boards/safety.py ``fault_clear_hold_us``).
FAULT_CLEAR_HOLD_US: Final = 1_000_000

#: NMT states (canopen's names) in which the firmware's motion commands are honoured.
_OPERATIONAL: Final = "OPERATIONAL"


@mypyc_attr(allow_interpreted_subclasses=True)   # compiled (bus/_native.py); boards subclass it
class Firmware(Application):
    """What every emulated processor board shares, CANopen or not: the processor reset and the
    power switch (:class:`Board` and the USB gateway, :class:`boards.usb_gateway.UsbGateway`).

    A subclass sets ``scheduler``, ``node_id``, ``name``, ``can`` (its
    :class:`boards.peripherals.CanController`) and ``reset_cause = "power_on"``,
    ``reset_count = 0``, ``started = False`` in its constructor, and implements
    :meth:`_init_state` (RAM to power-on values), :meth:`_hardware_reset` (timers, CAN
    controller, peripherals) and :meth:`start` (boot). ``reset_cause`` and ``reset_count``
    survive resets (the RCON register and a persistent boot counter).
    """

    KIND: ClassVar[str] = "firmware"
    #: EDS of this board kind (a key of ``bus.eds.objects.KINDS``); "" = no CANopen device
    CANOPEN_KIND: ClassVar[str] = ""
    #: the RS232 telemetry UART (:class:`boards.peripherals.Uart`), None without one
    uart: Optional[Uart] = None
    # set by every subclass's constructor (declared here: the compiled class lays them out)
    scheduler: Scheduler
    node_id: int
    name: str
    can: CanController
    reset_cause: str
    reset_count: int
    started: bool

    def _init_state(self) -> None:
        raise NotImplementedError

    def _hardware_reset(self) -> None:
        raise NotImplementedError

    def _volatile_reset(self) -> None:
        """Hook of :meth:`reset` between the hardware reset and the RAM reset (what a processor
        reset clears that :meth:`power_off` keeps for the report)."""

    def start(self) -> None:
        raise NotImplementedError

    @property
    def status_name(self) -> str:
        """The board's state for the report's board row."""
        return "RUNNING" if self.started else "OFF"

    def report_counters(self) -> dict:
        """Counters of this board kind for the report's board row (besides the ones every board
        has: malformed frames, state, reset cause and count). A board kind with counters of its
        own overrides this; the report (``host.network.Telescope.board_summary``) needs no change."""
        return {}

    def reset(self, cause: str = "power_on") -> None:
        """Processor reset; what survives: see the class docstring.

        Parameters
        ----------
        cause : {"power_on", "watchdog", "software"}

        Raises
        ------
        ValueError
            Unknown cause.
        """
        if cause not in RESET_CAUSES:
            raise ValueError(f"reset cause must be one of {sorted(RESET_CAUSES)}, got {cause!r}")
        was_running = self.started
        self._hardware_reset()
        self._volatile_reset()
        self.reset_cause = cause
        self.reset_count += 1
        self.started = False
        self._init_state()
        if was_running:
            self.start()

    def power_off(self) -> None:
        """Remove the board's power: ISRs stop, outputs go to their reset state, nothing is sent
        or received until :meth:`start` (power on again, cause ``power_on``)."""
        self._hardware_reset()
        self.started = False
        self.reset_cause = "power_on"


@mypyc_attr(allow_interpreted_subclasses=True)
class Board(Firmware):
    """Base class of the CANopen board firmwares.

    Parameters
    ----------
    scheduler : Scheduler
        The simulation clock.
    bus : can.BusABC
        This board's bus handle (one per board; ``schmidt-sim`` gives the receive interrupt).
    node_id : int
        CAN node id (1..127, CiA 301).
    name : str, optional
        Owner name for scheduler errors, e.g. ``"ra-axis"``.
    background_period_us : int
        Period of the background loop, µs.
    rx_buffers : int
        CAN controller hardware receive buffers (2: MCP2515, PIC18F4480 ECAN mode 0).
    serial_port : object, optional
        RS232 port for the telemetry packets (pyserial ``write()`` API: a
        ``bus.serial_link.SerialEnd`` or a ``serial.Serial``); None = no telemetry.
    telemetry_period_us : int
        Spacing of the telemetry samples, µs (10 000, §3.4); the subclass calls
        :meth:`telemetry_sample` at this period.
    """

    DEVICE_TYPE: ClassVar[int] = 0x00
    KIND: ClassVar[str] = "board"
    #: EDS of this board kind (a key of ``bus.eds.objects.KINDS``)
    CANOPEN_KIND: ClassVar[str] = ""

    def __init__(self, scheduler: Scheduler, bus: Any, node_id: int, *,
                 name: Optional[str] = None, background_period_us: int = 5_000,
                 rx_buffers: int = 2, serial_port=None,
                 telemetry_period_us: int = tlm.SAMPLE_PERIOD_US) -> None:
        if not 1 <= int(node_id) <= 127:      # CiA 301 node ids
            raise ValueError(f"node_id must be 1..127 (CiA 301), got {node_id}")
        self.scheduler = scheduler
        self.node_id = int(node_id)
        self.name = name or f"{self.KIND}-{self.node_id}"
        self.can = CanController(bus, rx_buffers=rx_buffers)
        self.can.accept = self._accept
        self.can.on_rx = self._on_rx
        self.can.on_frame = self._on_frame
        self.background_period_us = int(background_period_us)
        if not self.can.has_rx_interrupt:
            # a polled CAN controller (python-can ``virtual``, SocketCAN): its two receive
            # buffers must be emptied at least every POLL_PERIOD_US, or a board with a slow main
            # loop (display 250 ms, weather 1 s) loses frames, its SDO requests included
            self.background_period_us = min(self.background_period_us, POLL_PERIOD_US)
        self._background_timer = Timer(scheduler, self.background_period_us, self._background,
                                       priority=PRIO_BACKGROUND, owner=f"{self.name}/background")
        self._timers: List[Timer] = [self._background_timer]
        #: the CANopen services (docs/canopen.md); frames leave through the CAN controller
        self.device = CanopenDevice(scheduler, self.CANOPEN_KIND, self.node_id, self.can.send,  # type: ignore[arg-type]
                                    self, name=self.name)
        # NMT, SDO, the RPDOs (commands, LIMIT, STOP_ALL) and every node's heartbeat (the
        # consumer times in 0x1016 may be changed by SDO; the device ignores the others)
        self._accepted_ids = set(self.device.accepted_ids) | {
            proto.heartbeat_cob_id(n) for n in proto.ALL_NODES if n != self.node_id}
        self._firmware_ids: set = set()
        self._stop_all_id = proto.stop_all_cob_id()
        self._tpdo_ids = frozenset(self.device.tpdo_ids)
        #: the device's PDO gate, called natively on every PDO sent and received
        self._pdo: PdoGate = self.device.pdo
        self.uart = Uart(serial_port) if serial_port is not None else None
        #: True when the firmware samples telemetry (a port is wired)
        self.telemetry_enabled = self.uart is not None
        self.telemetry_period_us = int(telemetry_period_us)
        # persistent across resets (RCON-like)
        self.reset_cause = "power_on"
        self.reset_count = 0
        self.started = False
        self._init_state()

    # ------------------------------------------------------------------ state
    def _init_state(self) -> None:
        self.malformed_frames = 0
        self.state = STATE_BOOT
        self.boot_us = self.scheduler.now_us
        self._tx_queue: List[tuple] = []
        self.faults_sent = 0
        self.refused_commands = 0
        # command log, object 0x2F01 (issue 10: the acknowledgement a host reads back by SDO)
        self.commands_received = 0
        self.last_command = 0
        self.last_refusal = 0
        #: active fault conditions {code: last time the condition was present, µs}
        self.active_faults: Dict[int, int] = {}
        self.faults_suppressed = 0           # occurrences folded into an active condition
        self._mf_tokens = float(MALFORMED_FAULT_BURST)
        self._mf_t_us = self.scheduler.now_us
        self._tlm_values: list = []          # flat field values of the samples so far
        self._tlm_n = 0
        self._tlm_t0_us = 0
        self._tlm_ready: Optional[tuple] = None
        self.telemetry_seq = 0               # packets written since reset
        self.telemetry_dropped = 0           # packets overwritten before the loop wrote them

    def _peripherals(self) -> list:
        """Peripherals reset with the board (subclasses extend)."""
        return []

    def _all_peripherals(self) -> list:
        ps = self._peripherals()
        return ps + [self.uart] if self.uart is not None else ps

    def add_timer(self, timer: Timer) -> Timer:
        """Register a timer that :meth:`start` starts and :meth:`reset` stops."""
        self._timers.append(timer)
        return timer

    def accept_id(self, arbitration_id: int) -> None:
        """Add an identifier the firmware handles to the CAN acceptance filter."""
        self._accepted_ids.add(arbitration_id)
        self._firmware_ids.add(arbitration_id)

    # ------------------------------------------------------------------ lifecycle
    def start(self) -> None:
        """Boot: enable the receive interrupt (or polling), start the ISRs, CANopen boot-up
        (boot-up message, PRE-OPERATIONAL, heartbeat at the 0x1017 period)."""
        self.started = True
        self.boot_us = self.scheduler.now_us
        self.can.set_acceptance(self._accepted_ids)
        self.can.enable_rx_interrupt()
        t0 = self.scheduler.now_us
        for timer in self._timers:
            timer.start(t0)
        self.device.boot()
        self.state = STATE_OPERATIONAL
        if self.reset_cause == "watchdog":
            self.send_fault(FAULT_WATCHDOG, detail=self.reset_count)
        self.on_start()

    def on_start(self) -> None:
        """Hook for subclasses after boot."""

    @property
    def status_name(self) -> str:
        """The NMT state of the board's CANopen device."""
        return self.device.state

    def _volatile_reset(self) -> None:
        self.device.emcy.reset()             # active errors and the 0x1003 history are volatile

    def _hardware_reset(self) -> None:
        """Timers, CAN controller and peripherals to their reset state (reset and power-off)."""
        self.device.power_off()
        for timer in self._timers:
            timer.reset()
        self.can.reset()
        for p in self._all_peripherals():
            p.reset()

    # ------------------------------------------------------------------ CAN
    def _accept(self, arbitration_id: int) -> bool:
        return arbitration_id in self._accepted_ids

    def _on_rx(self, msg: can.Message) -> None:
        """Receive handler for a ``can.Message`` (polled buses: python-can ``virtual``,
        SocketCAN): a remote, extended or error frame is malformed here; a data frame goes to
        :meth:`_on_frame`."""
        if msg.is_remote_frame or msg.is_extended_id or msg.is_error_frame:
            self._malformed(msg.arbitration_id)
            return
        self._on_frame(msg.arbitration_id, bytes(msg.data))

    def _on_frame(self, cob: int, data: bytes) -> None:
        """Receive handler for a standard data frame (called directly by the CAN controller on
        the ``schmidt-sim`` bus, which carries nothing else)."""
        try:
            # NMT, SDO, a heartbeat in 0x1016: only those go to the (interpreted) canopen services
            consumed = cob in self.device.service_ids and self.device.receive(cob, data)
            if proto.FC_HEARTBEAT < cob <= proto.FC_HEARTBEAT + 0x7F:
                # a heartbeat the firmware watches too (the axis's host watchdog, 0x710) reaches
                # it even when 0x1016 consumes the same heartbeat; in every NMT state
                if cob in self._firmware_ids:
                    self.handle_frame(cob, data)
                return
            if consumed:
                return
            if not self._pdo.accept_rpdo():
                return                                  # process data outside OPERATIONAL
            if cob == self._stop_all_id:
                b = proto.decode_stop_all(data)
                if b.target_node in (0, self.node_id):
                    self.stop_all()
            else:
                self.handle_frame(cob, data)
        except MalformedFrame:
            self._malformed(cob)

    def _malformed(self, cob: int) -> None:
        """Count a malformed frame; FAULT MALFORMED (detail = its identifier) within the rate
        limit (token bucket), else counted in ``faults_suppressed``."""
        self.malformed_frames += 1
        now = self.scheduler.now_us
        tokens = min(float(MALFORMED_FAULT_BURST),
                     self._mf_tokens + (now - self._mf_t_us) * MALFORMED_FAULT_RATE_HZ * 1e-6)
        self._mf_t_us = now
        if tokens >= 1.0:
            self._mf_tokens = tokens - 1.0
            self.send_fault(FAULT_MALFORMED, detail=cob)
        else:
            self._mf_tokens = tokens
            self.faults_suppressed += 1

    def handle_frame(self, arbitration_id: int, data: bytes) -> None:
        """Decode and apply an accepted frame; raise ``MalformedFrame`` if it does not decode."""
        raise MalformedFrame(f"id 0x{arbitration_id:03X}", "identifier", "a frame this board handles")

    def stop_all(self) -> None:
        """STOP_ALL (0x190), or NMT leaving OPERATIONAL (subclasses stop their actuators)."""

    def send(self, arbitration_id: int, data: bytes) -> None:
        """Transmit now (used from the background loop and the receive handler). A TPDO of this
        node goes through the CANopen PDO gate: dropped (counted) unless NMT OPERATIONAL."""
        if arbitration_id in self._tpdo_ids:
            self._pdo.transmit_pdo(arbitration_id, data)
        else:
            self.can.send(arbitration_id, data)

    def queue(self, arbitration_id: Optional[int], data: Any) -> None:
        """Queue a frame for the background loop (what an ISR does instead of SPI transfers)."""
        self._tx_queue.append((arbitration_id, data))

    def _background(self, now_us: int) -> None:
        if not self.can.interrupt_enabled:
            self.can.poll()
        queue, self._tx_queue = self._tx_queue, []
        for arbitration_id, data in queue:
            if arbitration_id is None:           # a fault condition queued by an ISR
                self.fault_condition(data[0], now_us, data[1])
            else:
                self.send(arbitration_id, data)
        if self.active_faults:
            self._expire_faults(now_us)
        self.background(now_us)
        if self._tlm_ready is not None:
            self._write_telemetry()

    # ------------------------------------------------------------------ RS232 telemetry (§3.4)
    def telemetry_sample(self, now_us: int, values: tuple) -> None:
        """Record one 10 ms sample (call only when :attr:`telemetry_enabled`).

        Parameters
        ----------
        now_us : int
            Time of the sample, µs (the ISR's argument); the packet carries the board uptime.
        values : tuple of int
            The fields of :data:`bus.telemetry.SAMPLE_FIELDS` for this board's device type,
            already saturated to their widths.
        """
        if self._tlm_n == 0:
            self._tlm_t0_us = now_us - self.boot_us
        self._tlm_values.extend(values)
        self._tlm_n += 1
        if self._tlm_n == tlm.SAMPLES_PER_PACKET:
            if self._tlm_ready is not None:
                self.telemetry_dropped += 1
            self._tlm_ready = (self._tlm_t0_us, self._tlm_values)
            self._tlm_values = []
            self._tlm_n = 0

    def _write_telemetry(self) -> None:
        ready, uart = self._tlm_ready, self.uart
        assert ready is not None and uart is not None          # called only when a packet is ready
        t0_us, values = ready
        self._tlm_ready = None
        uart.write(tlm.encode_packet(self.DEVICE_TYPE, self.node_id, self.telemetry_seq, t0_us,
                                          values, self.telemetry_period_us))
        self.telemetry_seq = (self.telemetry_seq + 1) & 0xFFFF

    def background(self, now_us: int) -> None:
        """Hook for subclasses: background work after the queued frames are sent."""

    # ------------------------------------------------------------------ frames every board sends
    @property
    def uptime_s(self) -> int:
        """Whole seconds since the last boot."""
        return (self.scheduler.now_us - self.boot_us) // 1_000_000

    def crc_error_count(self) -> int:
        """CRC errors reported in FAULT frames (position readers override)."""
        return 0

    def queue_fault(self, code: int, detail: int = 0) -> None:
        """From an ISR: report fault condition ``code`` from the background loop."""
        self._tx_queue.append((None, (code, detail)))

    def fault_condition(self, code: int, now_us: int, detail: int = 0) -> None:
        """A fault condition is present now (call every time it is seen).

        The first occurrence sends FAULT ``code``; while the condition stays active (seen again
        within :data:`FAULT_CLEAR_HOLD_US`) nothing more is sent (counted in
        ``faults_suppressed``); once absent for that long, FAULT ``FAULT_CLEARED`` (detail =
        ``code``) is sent and the next occurrence is reported again. So repeats are rate-limited
        and every fault says when it clears.
        """
        if code in self.active_faults:
            self.faults_suppressed += 1
        else:
            self.send_fault(code, detail)
        self.active_faults[code] = now_us

    def clear_fault(self, code: int) -> None:
        """The condition ``code`` is known to be gone now: report FAULT_CLEARED (the EMCY error
        reset) at once; no-op if it is not active (neither here nor as an EMCY condition)."""
        held = self.active_faults.pop(code, None) is not None
        # ``emcy.is_active``, inlined: the EMCY service is interpreted and the axes ask every tick
        if held or EMCY_OF_FAULT[code] in self.device.emcy.active:
            self.send_fault(FAULT_CLEARED, detail=code)

    def _expire_faults(self, now_us: int) -> None:
        for code, seen in list(self.active_faults.items()):
            if now_us - seen >= self.fault_clear_hold_us:
                self.clear_fault(code)

    #: Hold time before a fault condition counts as cleared, µs (a subclass's constructor may
    #: set another after ``Board.__init__``; the axis controller's comes from its safety limits).
    fault_clear_hold_us: int = FAULT_CLEAR_HOLD_US

    def refuse(self, reason: int, cmd: int) -> None:
        """Report a refused command: FAULT ``COMMAND_REFUSED``, detail = reason << 8 | cmd.
        The caller leaves its state unchanged."""
        self.refused_commands += 1
        self.last_refusal = ((reason & 0xFF) << 8) | (cmd & 0xFF)
        self.send_fault(FAULT_REFUSED, detail=((reason & 0xFF) << 8) | (cmd & 0xFF))

    def send_fault(self, code: int, detail: int = 0) -> None:
        """Report fault ``code`` (``bus.protocol.FaultCode``) as a CANopen EMCY.

        An *event* (malformed frame, refused command, step loss, watchdog reset) sends one EMCY;
        a *condition* (CRC error, over-current, limit stop...) sends one EMCY when it becomes
        active and nothing more until :meth:`clear_fault` (``bus.eds.objects.EMCY_CODES``).
        ``FAULT_CLEARED`` with ``detail`` = a code sends the error reset of that condition
        (:meth:`clear_fault` and the hold expiry of :meth:`fault_condition` call it).
        """
        if code == FAULT_CLEARED:                 # the EMCY error reset of condition ``detail``
            self.device.emcy.clear(EMCY_OF_FAULT[detail])
            return
        self.faults_sent += 1
        self.device.emcy.report(EMCY_OF_FAULT[code], detail & 0xFFFF)

    # ------------------------------------------------------------------ CANopen application
    def note_command(self, cmd: int) -> None:
        """A command frame decoded (accepted or refused after): object 0x2F01 sub 1 and 2."""
        self.commands_received += 1
        self.last_command = int(cmd) & 0xFF

    def od_read(self, index: int, subindex: int):
        """SDO read of a manufacturer object (0x2F00 diagnostics, 0x2F01 command log here;
        subclasses add theirs)."""
        if index == 0x2F00:
            return {1: min(self.malformed_frames, 0xFFFF), 2: min(self.reset_count, 0xFFFF),
                    3: RESET_CAUSES[self.reset_cause], 4: self.uptime_s}.get(subindex)
        if index == 0x2F01:
            return {1: self.commands_received & 0xFFFF, 2: self.last_command,
                    3: min(self.refused_commands, 0xFFFF), 4: self.last_refusal}.get(subindex)
        return None

    def od_write(self, index: int, subindex: int, value) -> None:
        """SDO write of a manufacturer object (already range-checked against the EDS)."""
        raise ObjectRefused(reason=f"0x{index:04X}:{subindex} is read-only in the {self.KIND} firmware")

    def nmt_changed(self, old: str, new: str) -> None:
        """Leaving OPERATIONAL: the board can no longer receive commands, so it stops."""
        if old == _OPERATIONAL:
            self.stop_all()

    def reset_application(self) -> None:
        """NMT reset node: a processor reset with cause SOFTWARE (it boots the services again)."""
        self.reset("software")
