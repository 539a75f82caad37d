"""Firmware of the USB-HID CAN gateway (PIC18F4550 with an MCP2515 CAN controller), the host
PC's node on the bus (paper §3.4: "A CAN-to-USB board has been developed on a PIC18F4550 ...
configured as a HID device ... A total of 64 bytes are exchanged").

A transparent bridge: it sends on CAN exactly the frames the PC puts in OUT reports and passes
the CAN frames that its acceptance filters let through to the PC in IN reports, with a
timestamp. It sends nothing of its own on CAN. Report layout: :mod:`bus.hid_reports`; what the
PC sees and the limits: docs/usb-gateway.md.

Execution model (simulated time; the USB host's frame event drives the USB side):

* CAN receive interrupt (``schmidt-sim``) or, on a bus without one, a poll at every 1 ms SOF
  that takes every waiting frame (it stands in for the interrupts of the last ms): the frame is
  stamped (µs since boot) and appended to the CAN→PC queue of
  :data:`RX_QUEUE_FRAMES`; a frame arriving at a full queue is dropped, counted in
  ``rx_dropped`` and flagged (``RX_OVERFLOW``) in the next IN report, as a real gateway does.
* In its start-of-frame interrupt (every 1 ms), if the IN endpoint is free and the queue holds
  frames (or flags are pending), the firmware arms it with up to 4 frames; the host's IN token
  of the same frame takes it (assumed: the host schedules the interrupt transfer after SOF and
  the PIC's SOF ISR arms the buffer descriptor in time). So a frame reaches the PC at the next
  1 ms frame boundary while the queue is short, and at most 4 frames per ms reach it.
* OUT report interrupt: decode, send its frames on CAN in order, re-arm the OUT endpoint. A
  malformed report is counted (``out_malformed``, reason kept), flagged (``OUT_MALFORMED``) and
  its frames are not sent; the firmware never raises for it.
* Feature reports: GET = status counters; SET = commands (acceptance filters, clear counters);
  a malformed command is counted and stalled.

The PIC18F4550 has no CAN module: the CAN controller is an MCP2515 on SPI (assumed; it is the
controller the other PIC boards of the emulator use), modelled by
:class:`boards.peripherals.CanController` with its two receive buffers.

Not modelled: USB enumeration (configured at power-on), the MCP2515's three transmit buffers
(frames go straight to the bus's queue; at ≤ 4 frames per ms the 1 Mbit/s bus keeps up unless
others load it above ≈ 50 %), SPI transfer time, remote and extended frames (counted in
``rx_unsupported`` and not forwarded, as are frames of more than 8 data bytes a fuzzer hands the
receive path; the report layout carries 11-bit data frames of 0..8 bytes only).
"""

from __future__ import annotations

from collections import deque
from typing import ClassVar, Deque, Final, Optional

import can

from boards.firmware_base import Firmware
from boards.peripherals import FILTER_BEFORE_QUEUE_BUSES, CanController
from boards.usb_hid import UsbHidInterface
from bus import hid_reports as R
from bus import protocol as proto
from bus.scheduler import Scheduler
from mypy_extensions import mypyc_attr

__all__ = ["UsbGateway", "RX_QUEUE_FRAMES"]

#: CAN→PC queue depth, frames (assumed: 32 slots of 15 bytes = 480 B of the PIC18F4550's 2 KB
#: RAM, beside 1 KB of USB buffer RAM; 8 ms of the 4-frames-per-ms USB rate).
RX_QUEUE_FRAMES: Final = 32
_U32: Final = (1 << 32) - 1


@mypyc_attr(allow_interpreted_subclasses=True)   # compiled (bus/_native.py); may be subclassed
class UsbGateway(Firmware):
    """The USB-HID CAN gateway board (reset and power switch: :class:`boards.firmware_base.Firmware`).

    It has no CANopen device of its own (``CANOPEN_KIND = ""``): it is a transparent bridge,
    and node 0x10's CANopen roles (NMT master, SDO client, heartbeat producer, STOP_ALL
    TPDO1; ``bus/eds/host.eds``) are the PC's software, whose frames it carries. So it answers
    no SDO and sends no heartbeat or EMCY; its diagnostics are the status feature report.

    Parameters
    ----------
    scheduler : Scheduler
        The simulation clock.
    bus : can.BusABC
        The gateway's CAN bus handle (``schmidt-sim`` gives the receive interrupt).
    node_id : int
        CAN node id (default the host node, ``bus.protocol.NodeId.HOST`` = 0x10); reported in
        the status feature report. The gateway is the PC's node.
    name : str
        Owner name in scheduler errors.
    rx_queue_frames : int
        CAN→PC queue depth, frames (default :data:`RX_QUEUE_FRAMES`).
    usb : UsbHidInterface, optional
        The USB interface peripheral (default a new one); connect a
        :class:`bus.usb_link.UsbHostPort` to it.
    serial_port : None
        Accepted for the board registry's uniform constructor call; the gateway has no RS232
        telemetry (ValueError otherwise).
    """

    KIND: ClassVar[str] = "usb-gateway"

    def __init__(self, scheduler: Scheduler, bus: can.BusABC, node_id: int = proto.NodeId.HOST, *,
                 name: str = "usb-gateway", rx_queue_frames: int = RX_QUEUE_FRAMES,
                 usb: Optional[UsbHidInterface] = None, serial_port=None) -> None:
        if serial_port is not None:
            raise ValueError("the USB gateway has no RS232 telemetry port (serial_port must be None)")
        if int(rx_queue_frames) < 1:
            raise ValueError(f"rx_queue_frames must be >= 1, got {rx_queue_frames}")
        self.scheduler = scheduler
        self.node_id = int(node_id)
        self.name = name
        self.rx_queue_frames = int(rx_queue_frames)
        # The firmware takes each frame in the MCP2515's receive interrupt (2 buffers). On a bus
        # that cannot raise it at each frame's end (python-can virtual, socketcan) the 1 ms SOF
        # poll stands in for the interrupts of the last millisecond, so it takes every waiting
        # frame: a 2-buffer limit there would be an artefact of the emulation, not the board's
        # (the health check's five SDO answers within 1 ms were lost to it).
        has_irq = hasattr(bus, "set_rx_callback")
        # Transmit: one of the MCP2515's three buffers at a time (assumed firmware policy): with
        # three loaded at equal TXP the controller would send the last-loaded first (DS21801
        # §3.2), and a gateway must not reorder the PC's frames (SDO segments, command sequences)
        self.can = CanController(bus, rx_buffers=2 if has_irq else 1 << 30, tx_buffers=1)
        self.can.accept = self._accept
        self.can.on_rx = self._on_can_rx
        self.can.on_frame = self._on_can_frame
        self.usb = usb if usb is not None else UsbHidInterface()
        self.usb.on_sof = self._sof
        self.usb.on_in_done = self._in_done
        self.usb.on_out = self._on_out
        self.usb.on_get_feature = self._get_feature
        self.usb.on_set_feature = self._set_feature
        self.usb.firmware_idle = self._idle
        self.reset_cause = "power_on"   # survives resets (RCON)
        self.reset_count = 0
        self.started = False
        self._init_state()

    # ------------------------------------------------------------------ state
    def _init_state(self) -> None:
        self.boot_us = self.scheduler.now_us
        self.filters: tuple = ()
        self._queue: Deque[tuple] = deque()
        self._pending_flags = 0
        self.in_seq = 0
        self._hw_overruns_seen = 0
        self._armed_ts: list = []        # timestamps of the frames in the armed IN report
        # CAN → PC latency of the frames the PC took (emulator instrumentation for the report,
        # not in the status report; CLEAR_COUNTERS keeps them)
        self.latency_frames = 0
        self.latency_sum_us = 0
        self.latency_max_us = 0
        self._clear_counters()

    def _clear_counters(self) -> None:
        self.flags_seen = 0
        self.rx_frames = 0
        self.rx_dropped = 0
        self.rx_unsupported = 0
        self.tx_frames = 0
        self.tx_errors = 0
        self.in_reports = 0
        self.out_reports = 0
        self.out_malformed = 0
        self.last_malformed: int = R.MalformedReason.NONE
        self.queue_high_water = len(self._queue)

    @property
    def malformed_frames(self) -> int:
        """Malformed OUT reports and commands (the name every board's report row uses)."""
        return self.out_malformed

    def report_counters(self) -> dict:
        """The status report's counters (:meth:`status`) and the CAN → PC latency of the frames
        the PC took (µs from the frame's end on CAN to the USB host taking its IN report), for
        the report's board row."""
        st = self.status()
        n = self.latency_frames
        return {"rx_frames": st.rx_frames, "rx_dropped": st.rx_dropped, "rx_unsupported": self.rx_unsupported,
                "tx_frames": st.tx_frames, "tx_errors": st.tx_errors, "in_reports": st.in_reports,
                "out_reports": st.out_reports, "out_malformed": st.out_malformed,
                "last_malformed": R.MalformedReason(st.last_malformed).name.lower(),
                "queue_depth": st.queue_depth, "queue_high_water": st.queue_high_water,
                "hw_overruns": st.hw_overruns, "flags_seen": st.flags,
                "can_to_pc_latency_us": {"frames": n, "mean": round(self.latency_sum_us / n, 1) if n else None,
                                         "max": self.latency_max_us if n else None}}

    @property
    def queue_level(self) -> int:
        """Frames waiting in the CAN→PC queue."""
        return len(self._queue)

    # ------------------------------------------------------------------ lifecycle
    def start(self) -> None:
        """Power on: CAN receive interrupt (or polling at SOF), accept all, USB configured."""
        self.started = True
        self.boot_us = self.scheduler.now_us
        self._program_filters()
        self.can.enable_rx_interrupt()
        self.usb.attach()
        self.usb.arm_out()

    def _hardware_reset(self) -> None:
        """CAN controller and USB module to their reset state (reset and power-off: the USB
        device disappears from the PC until :meth:`start`). A processor reset
        (:meth:`Firmware.reset`) also clears the queue, the filters and the counters."""
        self.can.reset()
        self.usb.reset()

    @property
    def status_name(self) -> str:
        """``"CONFIGURED"`` while the PC sees the USB device (USB 2.0 §9.1 device state),
        ``"OFF"`` before :meth:`start` and after :meth:`power_off`."""
        return "CONFIGURED" if self.usb.configured else "OFF"

    # ------------------------------------------------------------------ CAN side
    def _accept(self, arbitration_id: int) -> bool:
        filters = self.filters
        return not filters or R.filter_matches(filters, arbitration_id)

    def _program_filters(self) -> None:
        bus = self.can.bus
        if type(bus).__name__ not in FILTER_BEFORE_QUEUE_BUSES:
            return  # the software check in _accept filters (see CanController.set_acceptance)
        bus.set_filters([{"can_id": f.filter_id, "can_mask": f.mask, "extended": False}
                         for f in self.filters] or None)

    def _on_can_rx(self, msg: can.Message) -> None:
        if (msg.is_remote_frame or msg.is_extended_id or msg.is_error_frame or msg.is_fd
                or len(msg.data) > 8            # (> 8 bytes: found by the fuzzer, host/fuzz.py)
                or not 0 <= msg.arbitration_id <= 0x7FF):    # a "standard" id out of range
            self.rx_unsupported += 1
            return
        self._on_can_frame(msg.arbitration_id, bytes(msg.data))

    def _on_can_frame(self, arbitration_id: int, data: bytes) -> None:
        """A standard data frame of 0..8 bytes (the CAN controller calls this directly on the
        ``schmidt-sim`` bus, which carries nothing else; :meth:`_on_can_rx` after its checks)."""
        q = self._queue
        if not q:                           # the USB host may be idle only with an empty queue
            self.usb.wake(False)
        if len(q) >= self.rx_queue_frames:
            self.rx_dropped += 1
            self._raise(R.InFlags.RX_OVERFLOW)
            return
        # a report slot's fields as encode_report packs them: id, DLC, data, timestamp
        q.append((arbitration_id, len(data), data, (self.scheduler.now_us - self.boot_us) & _U32))
        self.rx_frames += 1
        if len(q) > self.queue_high_water:
            self.queue_high_water = len(q)

    def _idle(self) -> bool:
        """The SOF interrupt has nothing to do: receive interrupt on, queue empty, no flags."""
        return (self.can.interrupt_enabled and not self._queue and not self._pending_flags
                and self.can.rx_overflows == self._hw_overruns_seen)

    def _raise(self, flag: int) -> None:
        self._pending_flags |= flag
        self.flags_seen |= flag

    # ------------------------------------------------------------------ USB side
    def _stage_in(self) -> None:
        usb = self.usb
        if not usb.configured or usb.in_armed or not (self._queue or self._pending_flags):
            return
        q = self._queue
        n = min(R.FRAMES_PER_REPORT, len(q))
        # R.encode_report without its per-frame checks: the frames come off the CAN bus (11-bit
        # ids, <= 8 bytes, checked in _on_can_rx) already as slot fields (same bytes: tested)
        vals = [R.KIND_IN, n, self._pending_flags & 0xFF, self.in_seq & 0xFF]
        ts = []
        for _ in range(n):
            f = q.popleft()
            vals += f
            ts.append(f[3])
        self._armed_ts = ts
        usb.arm_in(R.pack_report(n, vals))
        self._pending_flags = 0
        self.in_seq = (self.in_seq + 1) & 0xFF

    def _sof(self, now_us: int) -> None:
        if not self.can.interrupt_enabled:
            self.can.poll()
        if self.can.rx_overflows != self._hw_overruns_seen:
            self._hw_overruns_seen = self.can.rx_overflows
            self._raise(R.InFlags.CAN_HW_OVERRUN)
        self._stage_in()

    def _in_done(self, now_us: int) -> None:
        self.in_reports += 1
        if self._armed_ts:
            up = now_us - self.boot_us
            lat = [(up - ts) & _U32 for ts in self._armed_ts]
            self._armed_ts = []
            self.latency_frames += len(lat)
            self.latency_sum_us += sum(lat)
            self.latency_max_us = max(self.latency_max_us, *lat)

    def _malformed(self, reason: int) -> None:
        self.out_malformed += 1
        self.last_malformed = reason
        self._raise(R.InFlags.OUT_MALFORMED)

    def _on_out(self, report: bytes, now_us: int) -> None:
        self.out_reports += 1
        try:
            rep = R.decode_report(report, R.KIND_OUT)
        except R.ReportError as exc:
            self._malformed(exc.reason)
        else:
            for f in rep.frames:
                if self.can.send(f.arbitration_id, f.data):
                    self.tx_frames += 1
                else:
                    self.tx_errors += 1
                    self._raise(R.InFlags.CAN_TX_ERROR)
        self.usb.arm_out()

    def status(self) -> R.Status:
        """The counters as the status feature report carries them."""
        return R.Status(
            flags=self.flags_seen, filters=len(self.filters), node_id=self.node_id,
            uptime_us=(self.scheduler.now_us - self.boot_us) & _U32, rx_frames=self.rx_frames,
            rx_dropped=self.rx_dropped, tx_frames=self.tx_frames, tx_errors=self.tx_errors,
            in_reports=self.in_reports, out_reports=self.out_reports, out_malformed=self.out_malformed,
            queue_depth=self.rx_queue_frames, queue_level=len(self._queue),
            queue_high_water=self.queue_high_water, hw_overruns=self.can.rx_overflows,
            last_malformed=int(self.last_malformed))

    def _get_feature(self) -> bytes:
        return R.encode_status(self.status())

    def _set_feature(self, report: bytes) -> bool:
        try:
            cmd = R.decode_command(report)
        except R.ReportError as exc:
            self._malformed(exc.reason)
            self.usb.wake(True)                 # the OUT_MALFORMED flag goes in the next IN report
            return False
        if cmd.cmd == R.CMD_SET_FILTERS:
            self.filters = cmd.filters
            self._program_filters()
        elif cmd.cmd == R.CMD_CLEAR_COUNTERS:
            self._clear_counters()
        return True
