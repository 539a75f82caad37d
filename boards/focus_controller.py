"""Focus controller firmware (PIC18F4431), node 5 (paper §3.2, §3.3, §5.2).

The KM062 bipolar stepper is driven in half-step mode (0.9° per half step; 5 mm/rev ball screw
through a 1:2 belt → 6.25 µm of housing travel per half step, §3.2) by a dual H-bridge. The
firmware keeps an open-loop half-step position counter (what it commanded), generates one step
per step-timer interrupt while a move is pending, samples the LVDT output with the 10-bit ADC,
reads the motor's incremental shaft encoder with the PIC18F4431's quadrature encoder interface
(§3.3: "Its encoder feedback module is used for interfacing the incremental encoder on the
motor shaft") and watches the encoder index pulse (a port) for absolute referencing.

Emulated: FOCUS_COMMAND STOP / STEP ±n / MOVE_TO / HOLD (motor power off, regenerative holding
through the free-wheeling diodes, §3.3) / FREE (control power off); FOCUS_STATUS every 250 ms
(§5.2: "The LVDT and encoder values are displayed ... and refreshed every 250 ms") with the
LVDT counts, the half-step counter and the low 16 bits of the encoder count (the QEI's POSCNT).

**Missed steps.** Every 10 ms while steps are being issued (and at every FOCUS_STATUS, and every
10 ms when telemetry runs) the main loop reads the QEI (16-bit POSCNT extended in software,
:class:`boards.peripherals.Qei`) and compares it with the half-step counter: the deviation in
whole half-steps is ``round(enc_counts / counts_per_halfstep − pos_halfsteps)`` (tolerance ±½
half-step = ±2.5 counts). Every change of that deviation adds its size to ``missed_steps``,
latches FOCUS_STATUS flag STEP_LOSS until the next status, and sends FAULT code 6 STEP_LOSS
(detail = ``missed_steps``, the true total at the time of sending) at most once per second: a
loss detected within that second is not dropped but reported by the main loop as soon as the
second has passed, with the total then reached (issue 11: 7 lost half-steps were reported as 4). The counter is *not* corrected: the
half-step counter stays "commanded since reset", as in the paper's open-loop drive; the
operator re-references with LVDT and index (§3.3). Counts per half-step = encoder counts per
motor revolution / 400 half-steps per revolution (5 for the assumed 2000 counts/rev, see
plant/parameters.yaml ``focus.motor_encoder_counts_per_rev``).

RS232 telemetry (§3.4, optional ``serial_port``): the same 10 ms pass records a sample
(half-step counter, 32-bit encoder count, LVDT counts, missed steps, flags); a packet of 25 goes
out every 250 ms.

Not emulated: the 2 kHz LVDT excitation and its band-pass filter (analog; the port delivers
the demodulated LVDT voltage), acceleration ramps, automatic referencing with LVDT + index,
the QEI's index-reset mode and digital noise filter.

Assumed numbers (not in the paper): step rate 400 half-steps/s (one motor revolution per second,
2.5 mm/s of housing travel); travel ±800 half-steps (±5 mm, the LVDT range of §3.2). A STEP or
MOVE_TO whose target lies outside the travel is refused (FAULT COMMAND_REFUSED, reason 6,
boards/safety.py) and changes nothing.
"""

from __future__ import annotations

import math
from typing import Callable, Final, Optional

import can

from boards.firmware_base import FAULT_STEP_LOSS, Board
from boards.safety import REFUSE_TRAVEL
from boards.peripherals import Adc, Qei, StepDir, Timer
from bus import protocol as proto
from bus.errors import MalformedFrame
from bus.scheduler import PRIO_ISR, Scheduler
from mypy_extensions import mypyc_attr

__all__ = ["FocusController", "STEP_RATE_HZ", "TRAVEL_HALFSTEPS", "HALFSTEP_UM",
           "HALFSTEPS_PER_REV", "ENCODER_COUNTS_PER_REV"]

STEP_RATE_HZ: Final = 400            # assumed
TRAVEL_HALFSTEPS: Final = 800        # ±5 mm / 6.25 µm
HALFSTEP_UM: Final = 6.25            # §3.2
HALFSTEPS_PER_REV: Final = 400       # 360° / 0.9° per half step (§3.2)
#: Motor encoder counts per motor revolution (assumed: 500 lines × 4 in the QEI's x4 mode; the
#: paper names no resolution; host/network.py passes plant/parameters.yaml's value).
ENCODER_COUNTS_PER_REV: Final = 2000
STEP_LOSS_FAULT_MIN_INTERVAL_US: Final = 1_000_000

F_MOVING, F_HOLDING, F_INDEX, F_POWER_OFF, F_STEP_LOSS = (
    int(f) for f in (proto.FocusFlags.MOVING, proto.FocusFlags.HOLDING, proto.FocusFlags.INDEX_SEEN,
                     proto.FocusFlags.POWER_OFF, proto.FocusFlags.STEP_LOSS))
CMD_STOP, CMD_STEP, CMD_MOVE_TO, CMD_HOLD, CMD_FREE = 0, 1, 2, 3, 4


@mypyc_attr(allow_interpreted_subclasses=True)   # compiled (bus/_native.py); may be subclassed
class FocusController(Board):
    """PIC18F4431 focus controller firmware.

    Parameters
    ----------
    scheduler, bus, name, serial_port
        As :class:`boards.firmware_base.Board`.
    node_id : int
        5.
    on_step : callable
        Port ``on_step(direction)``: one half step, direction ±1.
    read_lvdt_v : callable
        Port: demodulated LVDT output, V (0..5, sampled by the 10-bit ADC).
    read_index : callable, optional
        Port: encoder index line level (bool); sampled after each step and at each status.
    read_encoder_counts : callable, optional
        Port: the motor encoder's cumulative signed count (the QEI input). None: no encoder
        wired, FOCUS_STATUS reports 0 and no missed-step detection.
    encoder_counts_per_rev : int
        Encoder counts per motor revolution (assumed 2000, :data:`ENCODER_COUNTS_PER_REV`).
    on_power : callable, optional
        Port ``on_power(state)`` with ``"on"``, ``"hold"`` or ``"free"``.
    step_rate_hz : int
        Half steps per second while moving (assumed 400).
    travel_halfsteps : int
        Targets are clamped to ±this (800 = ±5 mm).
    status_period_us : int
        FOCUS_STATUS period, µs (250 000, §5.2).
    name : str, optional
        Owner name (default ``"focus-<node>"``; the network passes the registry name).
    serial_port : object, optional
        RS232 telemetry port with the pyserial ``write()`` API (None: no telemetry).
    """

    DEVICE_TYPE = int(proto.DeviceType.FOCUS_CONTROLLER)
    KIND = "focus"
    CANOPEN_KIND = "focus_controller"

    def __init__(self, scheduler: Scheduler, bus: can.BusABC, node_id: int = 5, *,
                 on_step: Callable[[int], None], read_lvdt_v: Callable[[], float] = lambda: 0.0,
                 read_index: Optional[Callable[[], bool]] = None,
                 on_power: Optional[Callable[[str], None]] = None,
                 step_rate_hz: int = STEP_RATE_HZ, travel_halfsteps: int = TRAVEL_HALFSTEPS,
                 status_period_us: int = 250_000, name: Optional[str] = None,
                 read_encoder_counts: Optional[Callable[[], int]] = None,
                 encoder_counts_per_rev: int = ENCODER_COUNTS_PER_REV, serial_port=None) -> None:
        # the main loop runs every 5 ms (it also polls CAN on buses without a receive interrupt);
        # every 2nd pass (10 ms) it reads the encoder and samples telemetry; FOCUS_STATUS goes
        # out every status_period_us of it
        super().__init__(scheduler, bus, node_id, name=name, background_period_us=5_000,
                         serial_port=serial_port, telemetry_period_us=10_000)
        if int(encoder_counts_per_rev) <= 0:
            raise ValueError("encoder_counts_per_rev must be > 0")
        self.status_period_us = int(status_period_us)
        if not 0 < step_rate_hz <= 1_000_000:
            raise ValueError("step_rate_hz must be in (0, 1e6]")
        self.step_period_us = int(round(1e6 / step_rate_hz))
        self.travel_halfsteps = int(travel_halfsteps)
        self.read_index = read_index
        self.stepper = StepDir(on_step, on_power, half_step=True)
        self.adc = Adc({"lvdt": read_lvdt_v})
        self.qei = Qei(read_encoder_counts) if read_encoder_counts is not None else None
        self.encoder_counts_per_rev = int(encoder_counts_per_rev)
        #: half-steps per encoder count (0.2 for 2000 counts/rev)
        self.halfsteps_per_count = HALFSTEPS_PER_REV / self.encoder_counts_per_rev
        self.step_timer = self.add_timer(Timer(scheduler, self.step_period_us, self.isr_step,
                                               priority=PRIO_ISR, owner=f"{self.name}/step"))
        self.accept_id(proto.focus_command_cob_id(self.node_id))
        self._init_focus_state()

    def _peripherals(self) -> list:
        return [self.stepper, self.adc] + ([self.qei] if self.qei is not None else [])

    def _init_state(self) -> None:
        super()._init_state()
        if hasattr(self, "stepper"):
            self._init_focus_state()

    def _init_focus_state(self) -> None:
        self.pos_halfsteps = 0
        self._next_status_us = self.status_period_us  # since boot
        self.target_halfsteps = 0
        self.index_seen = False
        self._index_level = False
        self.missed_steps = 0            # half-steps lost since reset (encoder vs counter)
        self.step_deviation = 0          # encoder − counter, whole half-steps, last check
        self.step_loss_seen = False      # latched until the next FOCUS_STATUS
        self._step_fault_us: Optional[int] = None
        self._step_fault_pending = False  # a loss not yet reported (rate limit)
        self._loop_passes = 0
        self._stepped = False            # half-steps issued since the last encoder check

    def report_counters(self) -> dict:
        """Missed half-steps (see :meth:`boards.firmware_base.Board.report_counters`)."""
        return {"missed_steps": self.missed_steps}

    def on_start(self) -> None:
        if self.qei is not None:
            self.qei.reset()             # POSCNT cleared at boot: the present count is the zero

    @property
    def enc_counts(self) -> int:
        """Motor encoder count since boot (32-bit software extension of POSCNT), counts."""
        return self.qei.extended if self.qei is not None else 0

    @property
    def moving(self) -> bool:
        """A move is pending."""
        return self.target_halfsteps != self.pos_halfsteps and self.stepper.power == "on"

    # ------------------------------------------------------------------ ISR
    def isr_step(self, now_us: int) -> None:
        """Step-timer ISR: one half step toward the target, sample the index line."""
        if self.moving:
            d = 1 if self.target_halfsteps > self.pos_halfsteps else -1
            self.stepper.set_direction(d)
            self.stepper.step()
            self.pos_halfsteps += d
            self._stepped = True
            self._sample_index()

    def _sample_index(self) -> None:
        if self.read_index is None:
            return
        level = bool(self.read_index())
        if level and not self._index_level:
            self.index_seen = True
        self._index_level = level

    def background(self, now_us: int) -> None:
        """Main loop (5 ms). Every 2nd pass (10 ms): read the encoder, check for missed steps,
        record a telemetry sample. Every ``status_period_us`` (250 ms): sample the LVDT, send
        FOCUS_STATUS."""
        self._loop_passes += 1
        fault_us = self._step_fault_us
        if (self._step_fault_pending and fault_us is not None
                and now_us - fault_us >= STEP_LOSS_FAULT_MIN_INTERVAL_US):
            self._send_step_fault(now_us)
        if self._loop_passes & 1 == 0:
            if self.qei is not None and (self._stepped or self.telemetry_enabled):
                self._check_steps(now_us)
            if self.telemetry_enabled:
                p = self.pos_halfsteps
                self.telemetry_sample(now_us, (
                    -32768 if p < -32768 else (32767 if p > 32767 else p), self.enc_counts,
                    self.adc.sample("lvdt"), min(self.missed_steps, 0xFFFF), self.status_flags()))
        if now_us - self.boot_us < self._next_status_us:
            return
        self._next_status_us += self.status_period_us
        if self.qei is not None:
            self._check_steps(now_us)
        self._sample_index()
        lvdt = self.adc.sample("lvdt")
        self.send(proto.focus_status_cob_id(self.node_id),
                  proto.encode_focus_status(self.status_flags(), lvdt, self.pos_halfsteps,
                                            self.enc_counts))
        self.index_seen = False          # latched until reported
        self.step_loss_seen = False

    def _check_steps(self, now_us: int) -> None:
        """Read the QEI and compare it with the half-step counter (see module doc)."""
        self._stepped = False
        qei = self.qei
        assert qei is not None                     # called only with an encoder wired
        qei.read_delta()
        dev = math.floor(qei.extended * self.halfsteps_per_count - self.pos_halfsteps + 0.5)
        if dev == self.step_deviation:
            return
        self.missed_steps += abs(dev - self.step_deviation)
        self.step_deviation = dev
        self.step_loss_seen = True
        if (self._step_fault_us is None
                or now_us - self._step_fault_us >= STEP_LOSS_FAULT_MIN_INTERVAL_US):
            self._send_step_fault(now_us)
        else:
            self._step_fault_pending = True      # reported when the second has passed

    def _send_step_fault(self, now_us: int) -> None:
        self._step_fault_us = now_us
        self._step_fault_pending = False
        self.send_fault(FAULT_STEP_LOSS, detail=min(self.missed_steps, 0xFFFF))

    def status_flags(self) -> int:
        """FOCUS_STATUS flags byte."""
        f = 0
        if self.moving:
            f |= F_MOVING
        if self.stepper.power == "hold":
            f |= F_HOLDING
        if self.index_seen:
            f |= F_INDEX
        if self.stepper.power == "free":
            f |= F_POWER_OFF
        if self.step_loss_seen:
            f |= F_STEP_LOSS
        return f

    # ------------------------------------------------------------------ commands
    def _clamp(self, target: int) -> int:
        return max(-self.travel_halfsteps, min(self.travel_halfsteps, int(target)))

    def handle_frame(self, arbitration_id: int, data: bytes) -> None:
        if arbitration_id != proto.focus_command_cob_id(self.node_id):
            super().handle_frame(arbitration_id, data)
            return
        c = proto.decode_focus_command(data)
        self.note_command(c.cmd)
        if c.cmd == CMD_STOP:
            self.target_halfsteps = self.pos_halfsteps
        elif c.cmd in (CMD_STEP, CMD_MOVE_TO):
            target = self.target_halfsteps + c.value if c.cmd == CMD_STEP else c.value
            if not -self.travel_halfsteps <= target <= self.travel_halfsteps:
                self.refuse(REFUSE_TRAVEL, c.cmd)     # state unchanged
                return
            self.stepper.set_power("on")
            self.target_halfsteps = int(target)
        elif c.cmd == CMD_HOLD:
            self.target_halfsteps = self.pos_halfsteps
            self.stepper.set_power("hold")
        elif c.cmd == CMD_FREE:
            self.target_halfsteps = self.pos_halfsteps
            self.stepper.set_power("free")
        else:   # decoder already checks; kept for safety of future commands
            raise MalformedFrame("FOCUS_COMMAND", "cmd", "0..4", c.cmd)

    def stop_all(self) -> None:
        """STOP_ALL: stop stepping (motor stays energised)."""
        self.target_halfsteps = self.pos_halfsteps

    # ------------------------------------------------------------------ CANopen objects (SDO)
    def od_read(self, index: int, subindex: int):
        """0x2200 travel and step rate; 0x2201 the LVDT reference once an operator stored one."""
        if index == 0x2200:
            return {1: self.travel_halfsteps,
                    2: int(round(1e6 / self.step_period_us))}.get(subindex)
        if index == 0x2201:
            return getattr(self, "lvdt_reference_adc", None)   # none stored: SDO abort "no data"
        return super().od_read(index, subindex)

    def od_write(self, index: int, subindex: int, value) -> None:
        """Travel (targets clamped to it from the next command) and the LVDT reference
        (stored for the operator, not used by the firmware: docs/boards.md)."""
        if index == 0x2200 and subindex == 1:
            self.travel_halfsteps = int(value)
        elif index == 0x2201:
            self.lvdt_reference_adc = int(value)
        else:
            super().od_write(index, subindex, value)
