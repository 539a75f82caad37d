"""Focus controller firmware (PIC18F4431), node 5 (paper §3.2, §3.3, §5.2).

The KM062 bipolar stepper is driven in half-step mode (0.9° per half step; 5 mm/rev ball screw
through a 1:2 belt → 6.25 µm of housing travel per half step, §3.2) by a dual H-bridge. The
firmware keeps an open-loop half-step position counter (what it commanded), generates one step
per step-timer interrupt while a move is pending, samples the LVDT output with the 10-bit ADC
for FOCUS_STATUS, and watches the encoder index pulse (a port) for absolute referencing.

Emulated: FOCUS_COMMAND STOP / STEP ±n / MOVE_TO / HOLD (motor power off, regenerative holding
through the free-wheeling diodes, §3.3) / FREE (control power off), FOCUS_STATUS every 250 ms
(§5.2 "refreshed every 250 ms"). Not emulated: the 2 kHz LVDT excitation and its band-pass
filter (analog; the port delivers the demodulated LVDT voltage), the motor's incremental encoder
counts (only its index pulse), acceleration ramps.

Assumed numbers (not in the paper): step rate 400 half-steps/s (one motor revolution per second,
2.5 mm/s of housing travel); travel ±800 half-steps (±5 mm, the LVDT range of §3.2) — targets
are clamped to it.
"""

from __future__ import annotations

from typing import Callable, Optional

import can

from boards.firmware_base import Board
from boards.peripherals import Adc, StepDir, Timer
from bus import protocol as proto
from bus.errors import MalformedFrame
from bus.scheduler import PRIO_ISR, Scheduler

__all__ = ["FocusController", "STEP_RATE_HZ", "TRAVEL_HALFSTEPS", "HALFSTEP_UM"]

STEP_RATE_HZ = 400            # assumed
TRAVEL_HALFSTEPS = 800        # ±5 mm / 6.25 µm
HALFSTEP_UM = 6.25            # §3.2

F_MOVING, F_HOLDING, F_INDEX, F_POWER_OFF = 0x01, 0x02, 0x04, 0x08
CMD_STOP, CMD_STEP, CMD_MOVE_TO, CMD_HOLD, CMD_FREE = 0, 1, 2, 3, 4


class FocusController(Board):
    """PIC18F4431 focus controller firmware.

    Parameters
    ----------
    scheduler : Scheduler
        The simulation clock.
    bus : can.BusABC
        This board's CAN bus handle.
    node_id : int
        5.
    on_step : callable
        Port ``on_step(direction)``: one half step, direction ±1.
    read_lvdt_v : callable
        Port: demodulated LVDT output, V (0..5, sampled by the 10-bit ADC).
    read_index : callable, optional
        Port: encoder index line level (bool); sampled after each step and at each status.
    on_power : callable, optional
        Port ``on_power(state)`` with ``"on"``, ``"hold"`` or ``"free"``.
    step_rate_hz : int
        Half steps per second while moving (assumed 400).
    travel_halfsteps : int
        Targets are clamped to ±this (800 = ±5 mm).
    status_period_us : int
        FOCUS_STATUS period, µs (250 000, §5.2).
    name : str
        Owner name.
    """

    DEVICE_TYPE = int(proto.DeviceType.FOCUS_CONTROLLER)
    KIND = "focus"

    def __init__(self, scheduler: Scheduler, bus: can.BusABC, node_id: int = 5, *,
                 on_step: Callable[[int], None], read_lvdt_v: Callable[[], float] = lambda: 0.0,
                 read_index: Optional[Callable[[], bool]] = None,
                 on_power: Optional[Callable[[str], None]] = None,
                 step_rate_hz: int = STEP_RATE_HZ, travel_halfsteps: int = TRAVEL_HALFSTEPS,
                 status_period_us: int = 250_000, name: str = "focus") -> None:
        # the main loop runs every 5 ms (it also polls CAN on buses without a receive interrupt);
        # FOCUS_STATUS goes out every status_period_us of it
        super().__init__(scheduler, bus, node_id, name=name, background_period_us=5_000)
        self.status_period_us = int(status_period_us)
        if not 0 < step_rate_hz <= 1_000_000:
            raise ValueError("step_rate_hz must be in (0, 1e6]")
        self.step_period_us = int(round(1e6 / step_rate_hz))
        self.travel_halfsteps = int(travel_halfsteps)
        self.read_index = read_index
        self.stepper = StepDir(on_step, on_power, half_step=True)
        self.adc = Adc({"lvdt": read_lvdt_v})
        self.step_timer = self.add_timer(Timer(scheduler, self.step_period_us, self.isr_step,
                                               priority=PRIO_ISR, owner=f"{self.name}/step"))
        self.accept_id(proto.focus_command_cob_id(self.node_id))
        self._init_focus_state()

    def _peripherals(self) -> list:
        return [self.stepper, self.adc]

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
            self._sample_index()

    def _sample_index(self) -> None:
        if self.read_index is None:
            return
        level = bool(self.read_index())
        if level and not self._index_level:
            self.index_seen = True
        self._index_level = level

    def background(self, now_us: int) -> None:
        """Main loop (5 ms); every ``status_period_us`` (250 ms): sample the LVDT, send FOCUS_STATUS."""
        if now_us - self.boot_us < self._next_status_us:
            return
        self._next_status_us += self.status_period_us
        self._sample_index()
        lvdt = self.adc.sample("lvdt")
        self.send(proto.focus_status_cob_id(self.node_id),
                  proto.encode_focus_status(self.status_flags(), lvdt, self.pos_halfsteps))
        self.index_seen = False          # latched until reported

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
        return f

    # ------------------------------------------------------------------ commands
    def _clamp(self, target: int) -> int:
        return max(-self.travel_halfsteps, min(self.travel_halfsteps, int(target)))

    def handle_frame(self, arbitration_id: int, data: bytes) -> None:
        if arbitration_id != proto.focus_command_cob_id(self.node_id):
            super().handle_frame(arbitration_id, data)
            return
        c = proto.decode_focus_command(data)
        if c.cmd == CMD_STOP:
            self.target_halfsteps = self.pos_halfsteps
        elif c.cmd == CMD_STEP:
            self.stepper.set_power("on")
            self.target_halfsteps = self._clamp(self.target_halfsteps + c.value)
        elif c.cmd == CMD_MOVE_TO:
            self.stepper.set_power("on")
            self.target_halfsteps = self._clamp(c.value)
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
