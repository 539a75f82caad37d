"""Axis controller firmware (dsPIC30F3011), node 1 = RA, node 2 = DEC (paper §3.3, §4).

Every 5 ms the timer ISR reads the QEI (incremental encoder through the 1:24.5 friction roller),
forms the axis rate from the count difference over one tick, samples both shunt currents with
the 10-bit ADC, runs the incremental PI of §4 (:class:`boards.control.IncrementalPI`), splits
the effort U into two PWM duties with the twin-motor drive law of §3.3, and every second tick
queues AXIS_STATUS and AXIS_AUX (10 ms). Commands arrive as AXIS_COMMAND frames; the axis's
EnDat position reader sends LIMIT frames.

RS232 telemetry (§3.4, optional ``serial_port``): in the same every-second-tick branch the ISR
records one 10 ms sample — control effort U (Q15), both PWM duty registers, the 32-bit QEI
count, the last tick's QEI difference, both shunt ADC counts, the setpoint (milli-″/s), mode
and status flags (:data:`bus.telemetry.SAMPLE_FIELDS`); the background loop writes a packet of
25 samples every 250 ms.

Velocity measurement and its quantisation
-----------------------------------------
One QEI count is 360°·3600/(4.608e6·24.5) = 0.011480″ of axis angle (§3.2: "0.011 arc sec").
Counted over one 5 ms tick, one count is 2.296″/s of axis rate: 15 % of the 15″/s tracking
rate. The firmware uses the per-tick difference as the paper describes ("encoder feedback
module ... for estimating the velocity", 5 ms sampling); the PI's integral action averages it.

Preset rates (axis rate, arcsec/s)
----------------------------------
See :data:`PRESET_RATES_ARCSEC_S`. Only SLEW and TRACK come from the paper.
"""

from __future__ import annotations

from typing import Callable, ClassVar, Final, Optional

import can

from bus import protocol as proto
from boards.control import DRIVE_LAWS, IncrementalPI
from boards.firmware_base import (FAULT_BRAKE_CUT, FAULT_HOST_TIMEOUT, FAULT_LIMIT_STOP,
                                  FAULT_OVERCURRENT, FAULT_OVERSPEED, FAULT_READER_LOST, Board)
from boards.safety import (DEFAULT_SAFETY, REFUSE_DUTY, REFUSE_GAIN, REFUSE_LIMIT, REFUSE_RATE,
                           REFUSE_READER,
                           SafetyLimits)
from boards.peripherals import Adc, Pwm, Qei, Timer
from boards.services import ObjectRefused
from boards.services.application import ABORT_VALUE_TOO_HIGH, ABORT_VALUE_TOO_LOW
from bus.errors import MalformedFrame
from bus.scheduler import PRIO_ISR, Scheduler
from bus.units import ARCSEC_PER_RAD, ARCSEC_PER_REV, Q15_FULL_SCALE, check_counter_fraction, duty_to_q15, q15_to_duty
from mypy_extensions import mypyc_attr

__all__ = ["AxisController", "AxisMode", "PRESET_RATES_ARCSEC_S", "QEI_COUNTS_PER_REV",
           "DEFAULT_KP", "DEFAULT_KI"]


class AxisMode:
    """Axis modes (byte 1 of AXIS_STATUS) and AXIS_COMMAND command codes."""

    # plain ints for the ISR's speed, taken from the protocol's enums (one source of truth)
    STOP: ClassVar[int] = int(proto.AxisMode.STOP)
    SLEW: ClassVar[int] = int(proto.AxisMode.SLEW)
    SET: ClassVar[int] = int(proto.AxisMode.SET)
    GUIDE: ClassVar[int] = int(proto.AxisMode.GUIDE)
    FINE: ClassVar[int] = int(proto.AxisMode.FINE)
    TRACK: ClassVar[int] = int(proto.AxisMode.TRACK)
    VELOCITY: ClassVar[int] = int(proto.AxisMode.VELOCITY)
    OPEN_LOOP: ClassVar[int] = int(proto.AxisMode.OPEN_LOOP)
    LIMIT_STOP: ClassVar[int] = int(proto.AxisMode.LIMIT_STOP)
    SET_KP: ClassVar[int] = int(proto.AxisCommand.SET_KP)  # commands, not modes
    SET_KI: ClassVar[int] = int(proto.AxisCommand.SET_KI)
    NAMES: ClassVar[tuple] = tuple(m.name for m in proto.AxisMode)


#: Incremental-encoder counts per axis revolution: 4.608e6 counts/rev (Gurley 8x60, §3.2)
#: × 24.5 (735:30 friction roller, §2.2).
QEI_COUNTS_PER_REV: Final = 4_608_000 * 245 // 10

#: Slew: Table 1 gives 12.583 rad/s at the motor; / 360.489 (§2.2) = 0.034906 rad/s at the
#: axis = 7199.748″/s ≈ 2.000°/s (the SDO object 0x2001:1 reads 7199748 milli-″/s).
SLEW_ARCSEC_S: Final = 12.583 / 360.489 * ARCSEC_PER_RAD

#: Preset axis rates, arcsec/s. ``(RA, DEC)`` per preset.
#:
#: ====== ============ ========= ===========================================================
#: preset RA ″/s       DEC ″/s   source
#: ====== ============ ========= ===========================================================
#: SLEW   7199.748     7199.748  Table 1 (12.583 rad/s motor / 360.489 ≈ 2°/s)
#: SET    600          600       assumed: the high speed of Figs. 6, 11 ("600 arc sec/s")
#: GUIDE  100          100       assumed: the low speed of Fig. 7 ("100 arc sec/s")
#: FINE   30           30        assumed: between guide and tracking (not in the paper)
#: TRACK  15.0         0         §1 "15 arc sec/s" (sidereal 15.041″/s); DEC does not track
#:                               on an equatorial mount (§2.1)
#: ====== ============ ========= ===========================================================
PRESET_RATES_ARCSEC_S: Final = {
    AxisMode.SLEW: (SLEW_ARCSEC_S, SLEW_ARCSEC_S),
    AxisMode.SET: (600.0, 600.0),
    AxisMode.GUIDE: (100.0, 100.0),
    AxisMode.FINE: (30.0, 30.0),
    AxisMode.TRACK: (15.0, 0.0),
}

#: Default gains: :func:`boards.tuning.pi_gains_from_model` for the RA axis of
#: plant/parameters.yaml (J = 1760 kg·m² §4, σ2 = 6700 N·m·s/rad Table 2 low preload,
#: N = 360.489, assumed R = 1.2 Ω, L = 1.5 mH, K = 0.35 N·m/A, rotor inertia 2 × 3e-4 kg·m²,
#: p = 0.25, 24 V, 5 ms, dead time Δt). host/network.py should compute the gains per axis.
DEFAULT_KP: Final = 4.17e-4      # duty per (″/s)
DEFAULT_KI: Final = 4.63e-5      # duty per (″/s) per tick

STATUS_LIMIT, STATUS_ANTIWINDUP, STATUS_OVERCURRENT, STATUS_FAULT = (
    int(f) for f in (proto.AxisStatusFlags.LIMIT_STOP, proto.AxisStatusFlags.ANTI_WINDUP,
                     proto.AxisStatusFlags.OVER_CURRENT, proto.AxisStatusFlags.FAULT))
POS_INVALID_FLAG: Final = int(proto.PositionFlags.INVALID)
POS_LOW_FLAG: Final = int(proto.PositionFlags.LOW_LIMIT)
POS_HIGH_FLAG: Final = int(proto.PositionFlags.HIGH_LIMIT)
POS_LOW_NEAR_FLAG: Final = int(proto.PositionFlags.LOW_NEAR)
POS_HIGH_NEAR_FLAG: Final = int(proto.PositionFlags.HIGH_NEAR)
LIMIT_LOW_NEAR_FLAG: Final = int(proto.LimitFlags.LOW_NEAR)
LIMIT_HIGH_NEAR_FLAG: Final = int(proto.LimitFlags.HIGH_NEAR)
LIMIT_LOW, LIMIT_HIGH, LIMIT_INVALID = (
    int(f) for f in (proto.LimitFlags.LOW_SOFT_LIMIT, proto.LimitFlags.HIGH_SOFT_LIMIT,
                     proto.LimitFlags.POSITION_INVALID))


@mypyc_attr(allow_interpreted_subclasses=True)   # compiled (bus/_native.py); may be subclassed
class AxisController(Board):
    """dsPIC30F3011 axis controller firmware.

    Parameters
    ----------
    scheduler, bus, name, serial_port
        As :class:`boards.firmware_base.Board`.
    node_id : int
        1 (RA) or 2 (DEC).
    read_qei_counts : callable
        Port: cumulative incremental-encoder count (int).
    on_duties : callable
        Port ``on_duties(duty_a, duty_b)`` (0..1 each; motor A drives +, motor B drives −).
    shunt_a_v, shunt_b_v : callable
        Ports: shunt voltages of motor A and B, V (0.1 Ω · armature current).
    kp : float
        Proportional gain, duty per (″/s) (default :data:`DEFAULT_KP`).
    ki : float
        Integral gain per tick, duty per (″/s) per tick (default :data:`DEFAULT_KI`).
    u_max : float
        Effort limit, duty fraction.
    counter_fraction : float
        p, the counter-motor fraction (0.10-0.25, §3.3); host passes the plant file's value.
    law : str
        Drive law name in :data:`boards.control.DRIVE_LAWS` (``"proportional"`` = the paper's).
    axis : int, optional
        0 RA, 1 DEC (default node_id − 1).
    limit_reader_node : int, optional
        Node whose LIMIT frames apply (default node_id + 2).
    tick_us : int
        ISR period, µs (5000, §3.3).
    status_every_ticks : int
        AXIS_STATUS/AXIS_AUX every this many ticks (2 → 10 ms).
    qei_counts_per_rev : int
        Encoder counts per axis revolution.
    shunt_ohm : float
        Shunt resistance, Ω (0.1, §3.3).
    overcurrent_a : float
        Flag threshold, A (6 A continuous rating, §3.2).
    overcurrent_trip : bool
        If True, an over-current also stops the drive (latched until the next motion command).
        Default False: the paper describes no trip.
    limit_stop : {"hold", "coast"}
        On a limit: "hold" = PI to zero rate and hold; "coast" = U = 0, duties 0.
    name : str, optional
        Owner name (default ``"axis-<node>"``; the network passes the registry name).
    serial_port : object, optional
        RS232 telemetry port with the pyserial ``write()`` API (None: no telemetry).
    safety : SafetyLimits
        Command bounds, braking strategy, watchdogs (:mod:`boards.safety`, docs/faults.md).
    """

    DEVICE_TYPE = int(proto.DeviceType.AXIS_CONTROLLER)
    KIND = "axis"
    CANOPEN_KIND = "axis_controller"

    def __init__(self, scheduler: Scheduler, bus: can.BusABC, node_id: int = 1, *,
                 read_qei_counts: Callable[[], int],
                 on_duties: Optional[Callable[[float, float], None]] = None,
                 shunt_a_v: Callable[[], float] = lambda: 0.0,
                 shunt_b_v: Callable[[], float] = lambda: 0.0,
                 kp: float = DEFAULT_KP, ki: float = DEFAULT_KI, u_max: float = 1.0,
                 counter_fraction: float = 0.25, law: str = "proportional",
                 axis: Optional[int] = None, limit_reader_node: Optional[int] = None,
                 tick_us: int = 5_000, status_every_ticks: int = 2,
                 qei_counts_per_rev: int = QEI_COUNTS_PER_REV, shunt_ohm: float = 0.1,
                 overcurrent_a: float = 6.0, overcurrent_trip: bool = False,
                 limit_stop: str = "hold", name: Optional[str] = None,
                 serial_port=None, safety: SafetyLimits = DEFAULT_SAFETY) -> None:
        if law not in DRIVE_LAWS:
            raise ValueError(f"unknown drive law {law!r}; valid: {sorted(DRIVE_LAWS)}")
        check_counter_fraction(counter_fraction)
        if limit_stop not in ("hold", "coast"):
            raise ValueError("limit_stop must be 'hold' or 'coast'")
        self.axis = (node_id - 1) if axis is None else int(axis)
        super().__init__(scheduler, bus, node_id, name=name,
                         background_period_us=tick_us, serial_port=serial_port,
                         telemetry_period_us=int(tick_us) * int(status_every_ticks))
        # COB-IDs of the periodic frames (fixed node id: not computed per tick)
        self._status_cob = proto.axis_status_cob_id(self.node_id)
        self._aux_cob = proto.axis_aux_cob_id(self.node_id)
        self.tick_us = int(tick_us)
        self.kp0, self.ki0, self.u_max = float(kp), float(ki), float(u_max)
        self.counter_fraction = float(counter_fraction)
        self.law_name = law
        self.law = DRIVE_LAWS[law]
        self.status_every_ticks = int(status_every_ticks)
        self.qei_counts_per_rev = int(qei_counts_per_rev)
        self.arcsec_per_count = ARCSEC_PER_REV / self.qei_counts_per_rev
        self.rate_per_count = self.arcsec_per_count / (self.tick_us * 1e-6)   # (″/s) per count
        self.shunt_ohm = float(shunt_ohm)
        self.overcurrent_a = float(overcurrent_a)
        self.overcurrent_trip = bool(overcurrent_trip)
        self.limit_stop_mode = limit_stop
        self.limit_reader_node = node_id + 2 if limit_reader_node is None else limit_reader_node
        self.safety = safety
        self.fault_clear_hold_us = int(safety.fault_clear_hold_us)
        self.slew_arcsec_s = SLEW_ARCSEC_S
        self.max_rate_arcsec_s = safety.max_rate_arcsec_s
        self.overspeed_arcsec_s = safety.max_rate_arcsec_s * safety.overspeed_factor
        self._brake_step = safety.brake_decel_arcsec_s2 * self.tick_us * 1e-6   # ″/s per tick

        self.pwm = Pwm(2, on_duties)
        self.qei = Qei(read_qei_counts)
        self.adc = Adc({"a": shunt_a_v, "b": shunt_b_v})
        self.timer = self.add_timer(Timer(scheduler, self.tick_us, self.isr_tick,
                                          priority=PRIO_ISR, owner=f"{self.name}/isr"))
        self.accept_id(proto.axis_command_cob_id(self.node_id))
        self.accept_id(proto.limit_cob_id(self.limit_reader_node))
        self._position_cob = proto.position_cob_id(self.limit_reader_node)
        self._host_hb_cob = proto.heartbeat_cob_id(int(proto.NodeId.HOST))
        self.accept_id(self._position_cob)        # reader liveness and validity
        self.accept_id(self._host_hb_cob)         # host heartbeat feeds the host watchdog
        self._init_axis_state()

    # ------------------------------------------------------------------ state
    def _peripherals(self) -> list:
        return [self.pwm, self.qei, self.adc]

    def _init_state(self) -> None:
        super()._init_state()
        if hasattr(self, "pwm"):
            self._init_axis_state()

    def _init_axis_state(self) -> None:
        #: this axis's preset magnitudes, ″/s by command (0x2001, rw; power-on values restored on reset)
        self.preset_rates_arcsec_s = {int(m): abs(r[min(self.axis, 1)]) for m, r in PRESET_RATES_ARCSEC_S.items()}
        self.pi = IncrementalPI(self.kp0, self.ki0, self.u_max)
        self.mode = AxisMode.STOP
        self.setpoint_arcsec_s = 0.0
        self.open_loop_u = 0.0
        self.omega_arcsec_s = 0.0
        self.qei_delta = 0
        self.adc_a = self.adc_b = 0
        self.current_a = (0.0, 0.0)
        self.overcurrent = False
        self.tripped = False
        self.limit_flags = 0              # effective: LIMIT-frame flags | POSITION-frame flags
        self._limit_frame_flags = 0       # from the reader's LIMIT frames (repeated every 100 ms)
        self._pos_limit_flags = 0         # from the limit bits of its POSITION frames (every 10 ms)
        self._frame_near = 0              # approach-zone bits (as LIMIT_LOW/HIGH) from LIMIT frames
        self._pos_near = 0                # ... and from POSITION frames
        self._applied_sp = 0.0            # the setpoint the PI last ran with, ″/s
        self.position_invalid = False
        self.limit_refusals = 0
        # braking and supervision (boards/safety.py)
        now = self.scheduler.now_us
        self.braking = False
        self.brake_sp = 0.0
        self.brake_cut = False
        self._brake_bad = 0
        self._rest_us = 0
        self._brake_ramp_end_us = 0
        self._overspeed_ticks = 0
        self._host_us = now
        self.host_seen = False            # the host watchdog is armed by the first host frame
        self.host_timed_out = False
        self.reader_seen = False
        self._reader_us = now
        self.reader_invalid = False
        self.reader_lost = 0              # 0 ok, 1 silent, 2 invalid
        self._lost_limit_flags = 0
        self._limit_us = now
        self.ticks = 0
        self.aux_seq = 0
        self._tlm_sp = 0.0            # setpoint last converted for telemetry, ″/s
        self._tlm_sp_m = 0            # the same in milli-″/s (telemetry field)

    # ------------------------------------------------------------------ properties
    @property
    def u(self) -> float:
        """Control effort U, signed duty fraction."""
        return self.pi.u

    @property
    def duties(self) -> tuple:
        """PWM duties (motor A, motor B) as output (quantised)."""
        return self.pwm.duties

    @property
    def kp(self) -> float:
        """Proportional gain, duty per (″/s)."""
        return self.pi.kp

    @property
    def ki(self) -> float:
        """Integral gain, duty per (″/s) per tick."""
        return self.pi.ki

    def on_start(self) -> None:
        self.qei.reset()          # POSCNT cleared at boot: the present count is the zero
        self._write_outputs()

    # ------------------------------------------------------------------ ISR (5 ms)
    def isr_tick(self, now_us: int) -> None:
        """Timer ISR: sample QEI and ADC, run the PI, write the duties, set flags."""
        self.ticks += 1
        delta = self.qei.read_delta()
        self.qei_delta = delta
        self.omega_arcsec_s = delta * self.rate_per_count
        self.adc_a = self.adc.sample("a")
        self.adc_b = self.adc.sample("b")
        lsb = self.adc.lsb_v / self.shunt_ohm
        self.current_a = (self.adc_a * lsb, self.adc_b * lsb)
        over = max(self.current_a) > self.overcurrent_a
        if over:
            # reported once per occurrence, then rate-limited and cleared (Board.fault_condition)
            self.queue_fault(FAULT_OVERCURRENT, int(max(self.current_a) * 1000) & 0xFFFF)
        if over and not self.overcurrent:
            if self.overcurrent_trip:
                self.tripped = True
                self.mode = AxisMode.STOP
                self.setpoint_arcsec_s = 0.0
                self.pi.force(0.0)
        self.overcurrent = over
        self._supervise(now_us)

        if (self.tripped or self.brake_cut
                or (self.mode == AxisMode.LIMIT_STOP and self.limit_stop_mode == "coast")):
            self.pi.force(0.0)
            self._applied_sp = self.omega_arcsec_s
        elif self.mode == AxisMode.OPEN_LOOP:
            self.pi.force(self.open_loop_u, 0.0)
            self._applied_sp = self.omega_arcsec_s
        else:
            if (not self.braking and self.mode in (AxisMode.STOP, AxisMode.LIMIT_STOP)
                    and abs(self.omega_arcsec_s) > self.safety.brake_stop_tol_arcsec_s):
                self._brake(self.mode)       # a hold that moves (e.g. an unstable loop): supervise again
            if self.braking:
                self._brake_tick(now_us)
            if not self.brake_cut:
                sp = self.setpoint_arcsec_s
                near = self._frame_near | self._pos_near
                if near and not self.braking and ((sp > 0 and near & LIMIT_HIGH) or (sp < 0 and near & LIMIT_LOW)):
                    sp = self._approach(sp)
                self._applied_sp = sp
                self.pi.update(sp - self.omega_arcsec_s)
            else:
                self.pi.force(0.0)
        self._write_outputs()

        if self.ticks % self.status_every_ticks == 0:
            u_q15 = duty_to_q15(self.pi.u)
            flags = self.status_flags()
            delta = -32768 if delta < -32768 else (32767 if delta > 32767 else delta)
            self.queue(self._status_cob,
                       proto.encode_axis_status(self.mode, flags, u_q15, self.qei.extended))
            self.aux_seq = (self.aux_seq + 1) & 0xFF
            self.queue(self._aux_cob,
                       proto.encode_axis_aux(self.aux_seq, self.adc_a, self.adc_b, delta))
            if self.telemetry_enabled:
                if self.setpoint_arcsec_s != self._tlm_sp:      # convert only on a change
                    self._tlm_sp = sp = self.setpoint_arcsec_s
                    m = int(round(sp * 1000.0))
                    self._tlm_sp_m = -0x80000000 if m < -0x80000000 else min(m, 0x7FFFFFFF)
                pdc = self.pwm.duty_register
                self.telemetry_sample(now_us, (u_q15, pdc[0], pdc[1], self.qei.extended, delta,
                                               self.adc_a, self.adc_b, self._tlm_sp_m,
                                               self.mode, flags))

    # ------------------------------------------------------------------ safety (boards/safety.py)
    def _supervise(self, now_us: int) -> None:
        """Per tick: LIMIT expiry, position-reader and host watchdogs."""
        sf = self.safety
        w = self.omega_arcsec_s
        if w > self.overspeed_arcsec_s or w < -self.overspeed_arcsec_s:
            self._overspeed_ticks += 1
            if self._overspeed_ticks >= sf.brake_bad_ticks and not self.braking:
                self.queue_fault(FAULT_OVERSPEED, int(min(abs(w), 65535)))
                self._brake(AxisMode.STOP)
        else:
            self._overspeed_ticks = 0
        if (self._limit_frame_flags or self._frame_near) and now_us - self._limit_us > sf.limit_expiry_us:
            self._limit_frame_flags = self._frame_near = 0   # LIMIT frames stopped: the state expires
            self._apply_limits()
        if self._pos_limit_flags and now_us - self._reader_us > sf.limit_expiry_us:
            self._pos_limit_flags = 0                  # POSITION frames stopped: likewise
            self._apply_limits()
        if self.reader_seen:
            lost = (1 if now_us - self._reader_us > sf.reader_timeout_us
                    else (2 if self.reader_invalid else 0))
            if lost:
                if not self.reader_lost:
                    self._lost_limit_flags = self.limit_flags
                self.reader_lost = lost
                self.queue_fault(FAULT_READER_LOST, lost)
                if self.motion_sign() != 0 and not self._toward_safety(self.motion_sign()):
                    self._brake(AxisMode.STOP)
            elif self.reader_lost:
                self.reader_lost = 0
        wd = sf.host_watchdog_us
        if wd is not None and self.host_seen and now_us - self._host_us > wd:
            self.host_timed_out = True
            self.queue_fault(FAULT_HOST_TIMEOUT, wd // 1000)
            if self.motion_sign() != 0:
                self._brake(AxisMode.STOP)

    def _toward_safety(self, sign: int) -> bool:
        """With the reader lost, only motion away from the limit active when it was lost."""
        f = self._lost_limit_flags
        return bool((sign < 0 and f & LIMIT_HIGH) or (sign > 0 and f & LIMIT_LOW))

    def _brake(self, mode: int) -> None:
        """Start (or continue) the braking ramp toward rest; see boards/safety.py."""
        self.mode = mode
        self.open_loop_u = 0.0
        if not self.braking:
            self.braking = True
            # ramp from the measured rate, but never from above the rate the PI was running
            # at (a hold that moves, a QEI glitch: the ramp must not ask for more speed)
            w, cap = self.omega_arcsec_s, abs(self._applied_sp)
            self.brake_sp = w if abs(w) <= cap else (cap if w > 0 else -cap)
            self._brake_bad = 0
            self._rest_us = 0
            self._brake_ramp_end_us = (self.scheduler.now_us
                                       + int(abs(self.brake_sp) / self._brake_step) * self.tick_us)
        self.setpoint_arcsec_s = self.brake_sp

    def _brake_tick(self, now_us: int) -> None:
        """Advance the ramp one tick and supervise: cut the duty if the axis does not slow."""
        sf = self.safety
        r, step = self.brake_sp, self._brake_step
        r = r - step if r > step else (r + step if r < -step else 0.0)
        self.brake_sp = r
        self.setpoint_arcsec_s = r
        w = abs(self.omega_arcsec_s)
        if w > abs(r) + sf.brake_margin_arcsec_s:
            self._brake_bad += 1
        else:
            self._brake_bad = 0
        if r == 0.0 and w <= sf.brake_stop_tol_arcsec_s:
            self._rest_us += self.tick_us
        else:
            self._rest_us = 0
        late = r == 0.0 and now_us - self._brake_ramp_end_us > sf.brake_grace_us
        if self._brake_bad >= sf.brake_bad_ticks or (late and self._rest_us < sf.brake_rest_us):
            self.brake_cut = True
            self.braking = False
            self.setpoint_arcsec_s = 0.0
            self.pi.force(0.0)
            self.queue_fault(FAULT_BRAKE_CUT, int(min(w, 65535)))
        elif self._rest_us >= sf.brake_rest_us:
            self.braking = False                          # at rest: PI holds zero rate

    def _approach(self, sp: float) -> float:
        """Setpoint toward a limit inside its approach zone: the speed toward it may rise by at
        most the braking deceleration (boards/safety.py), so the reader's braking zone, computed
        from the rate it measures, is never outrun by a step of the setpoint (docs/faults.md)."""
        a, step = self._applied_sp, self._brake_step
        if abs(sp) <= abs(a) and sp * a >= 0:
            return sp                                   # slowing down (or same): at once
        return min(sp, a + step) if sp > 0 else max(sp, a - step)

    def _write_outputs(self) -> None:
        if self.tripped or self.brake_cut:
            self.pwm.set_duties(0.0, 0.0)
            return
        self.pwm.set_duties(*self.law(self.pi.u, self.counter_fraction))

    def status_flags(self) -> int:
        """AXIS_STATUS flags byte."""
        f = 0
        if self.limit_flags & (LIMIT_LOW | LIMIT_HIGH) or self.mode == AxisMode.LIMIT_STOP:
            f |= STATUS_LIMIT
        if self.pi.saturated:
            f |= STATUS_ANTIWINDUP
        if self.overcurrent:
            f |= STATUS_OVERCURRENT
        if self.tripped or self.position_invalid or self.brake_cut or self.reader_lost:
            f |= STATUS_FAULT
        return f

    # ------------------------------------------------------------------ commands
    def handle_frame(self, arbitration_id: int, data: bytes) -> None:
        if arbitration_id == self._position_cob:
            pos = proto.decode_position(data)
            self.reader_seen = True
            self._reader_us = self.scheduler.now_us
            self.reader_invalid = bool(pos.flags & POS_INVALID_FLAG)
            self._pos_near = ((LIMIT_LOW if pos.flags & POS_LOW_NEAR_FLAG else 0)
                              | (LIMIT_HIGH if pos.flags & POS_HIGH_NEAR_FLAG else 0))
            flags = ((LIMIT_LOW if pos.flags & POS_LOW_FLAG else 0)
                     | (LIMIT_HIGH if pos.flags & POS_HIGH_FLAG else 0))
            if flags != self._pos_limit_flags:
                self._pos_limit_flags = flags
                self._apply_limits()
        elif arbitration_id == proto.axis_command_cob_id(self.node_id):
            c = proto.decode_axis_command(data)
            self._host_alive()
            self.note_command(c.cmd)
            self._command(c)
        elif arbitration_id == proto.limit_cob_id(self.limit_reader_node):
            lim = proto.decode_limit(data)
            if lim.axis != self.axis:
                raise MalformedFrame("LIMIT", "axis", f"{self.axis}", lim.axis)
            self._limit_us = self.scheduler.now_us
            self._limit(lim.flags)
        elif arbitration_id == self._host_hb_cob:
            proto.decode_heartbeat(data)
            self._host_alive()
        else:
            super().handle_frame(arbitration_id, data)

    def _host_alive(self) -> None:
        self._host_us = self.scheduler.now_us
        self.host_seen = True
        if self.host_timed_out:
            self.host_timed_out = False

    def _direction(self, cmd: int, direction: int) -> int:
        if direction in (1, -1):
            return direction
        if direction == 0 and cmd in (AxisMode.VELOCITY, AxisMode.OPEN_LOOP):
            return 1
        raise MalformedFrame("AXIS_COMMAND", "direction", "+1 or -1", direction)

    def _command(self, c) -> None:
        cmd = c.cmd
        if cmd == AxisMode.STOP:
            self._brake(AxisMode.STOP)
            return
        if cmd in (AxisMode.SET_KP, AxisMode.SET_KI):
            gain = c.value * 1e-6
            tuned = self.kp0 if cmd == AxisMode.SET_KP else self.ki0
            band = self.safety.gain_band
            if not tuned / band <= gain <= tuned * band:
                self.refuse(REFUSE_GAIN, cmd)          # state unchanged
                return
            if cmd == AxisMode.SET_KP:
                self.pi.kp = gain
            else:
                self.pi.ki = gain
            return
        sign = self._direction(cmd, c.direction)
        if cmd == AxisMode.OPEN_LOOP:
            if abs(c.value) > Q15_FULL_SCALE:
                self.refuse(REFUSE_DUTY, cmd)
                return
            u = max(-self.u_max, min(self.u_max, sign * q15_to_duty(c.value)))
            if self._refuse(u, cmd):
                return
            self._start_motion()
            self.open_loop_u = u
            self.mode = AxisMode.OPEN_LOOP
            return
        if cmd == AxisMode.VELOCITY:
            rate = sign * c.value / 1000.0
            if abs(rate) > self.max_rate_arcsec_s:
                self.refuse(REFUSE_RATE, cmd)
                return
        else:
            rate = sign * self.preset_rates_arcsec_s[int(cmd)]
        if self._refuse(rate, cmd):
            return
        self._start_motion()
        self._set_mode(int(cmd), rate)

    def _start_motion(self) -> None:
        self.tripped = False
        self.brake_cut = False
        self.braking = False

    def _set_mode(self, mode: int, rate: float) -> None:
        # Bumpless: neither U nor E_{k-1} is touched (incremental form, see IncrementalPI).
        self.mode = mode
        self.setpoint_arcsec_s = float(rate)

    def _limit_active_toward(self, sign: float) -> bool:
        return bool((sign < 0 and self.limit_flags & LIMIT_LOW)
                    or (sign > 0 and self.limit_flags & LIMIT_HIGH))

    def _refuse(self, sign: float, cmd: int) -> bool:
        s = (sign > 0) - (sign < 0)
        if self.reader_lost and s != 0 and not self._toward_safety(s):
            self.refuse(REFUSE_READER, cmd)
            return True
        if self._limit_active_toward(sign):
            self.limit_refusals += 1
            self.refuse(REFUSE_LIMIT, cmd)
            return True
        return False

    def motion_sign(self) -> int:
        """Sign of the commanded motion (0 when stopped)."""
        if self.mode == AxisMode.OPEN_LOOP:
            x = self.open_loop_u
        elif self.mode in (AxisMode.STOP, AxisMode.LIMIT_STOP):
            return 0
        else:
            x = self.setpoint_arcsec_s
        return (x > 0) - (x < 0)

    def _limit(self, flags: int) -> None:
        """A LIMIT frame from the axis's reader."""
        self.position_invalid = bool(flags & LIMIT_INVALID)
        self._limit_frame_flags = flags & (LIMIT_LOW | LIMIT_HIGH)
        self._frame_near = ((LIMIT_LOW if flags & LIMIT_LOW_NEAR_FLAG else 0)
                            | (LIMIT_HIGH if flags & LIMIT_HIGH_NEAR_FLAG else 0))
        self._apply_limits(flags)

    def _apply_limits(self, detail: int | None = None) -> None:
        """Effective soft-limit state = LIMIT-frame flags | POSITION-frame limit bits.

        The reader reports its limit state twice, in every POSITION frame (10 ms) and in LIMIT
        frames (on change, repeated every 100 ms while active); a limit counts as active while
        either source says so, and clears only when both do. So one frame on the reader's
        COB-ID saying "no limit" (a faulty or spoofing node: the 10⁶-frame fuzz of docs/faults.md)
        cannot release an active limit; the real reader's next frame re-asserts it.
        """
        self.limit_flags = self._limit_frame_flags | self._pos_limit_flags
        if self._limit_active_toward(self.motion_sign()):
            self._brake(AxisMode.LIMIT_STOP)
            if self.limit_stop_mode == "coast":
                self.pi.force(0.0)
            if detail is None:                 # raised by a POSITION frame's limit bits
                detail = self.limit_flags | (LIMIT_INVALID if self.position_invalid else 0)
            self.send_fault(FAULT_LIMIT_STOP, detail=detail)
        elif self.mode == AxisMode.LIMIT_STOP and not self.limit_flags:
            self.mode = AxisMode.STOP

    def stop_all(self) -> None:
        """STOP_ALL (0x190) or NMT leaving OPERATIONAL: controlled stop (braking ramp, supervised)."""
        self._brake(AxisMode.STOP)

    def background(self, now_us: int) -> None:
        """The limit-stop condition ends when the axis leaves LIMIT_STOP: EMCY error reset."""
        if self.mode != AxisMode.LIMIT_STOP:
            self.clear_fault(FAULT_LIMIT_STOP)

    # ------------------------------------------------------------------ CANopen objects (SDO)
    def od_read(self, index: int, subindex: int):
        """0x2000 PI controller (Kp, Ki x 1e6, effort limit, counter fraction Q15), 0x2001 preset
        rates (milli-arcsec/s, magnitudes for this axis); 0x2F00 from :class:`Board`."""
        if index == 0x2000:
            return {1: int(round(self.pi.kp * 1e6)), 2: int(round(self.pi.ki * 1e6)),
                    3: duty_to_q15(self.pi.u_max),
                    4: duty_to_q15(self.counter_fraction)}.get(subindex)
        if index == 0x2001 and 1 <= subindex <= 5:
            return int(round(self.preset_rates_arcsec_s[subindex] * 1000.0))   # sub n = command n
        return super().od_read(index, subindex)

    def od_write(self, index: int, subindex: int, value) -> None:
        """Kp, Ki (as SET_KP/SET_KI: bumpless, volatile, refused outside the same gain band,
        abort 0x06090031/0x06090032), effort limit, counter fraction."""
        if index == 0x2000 and subindex in (1, 2):
            gain = value * 1e-6
            tuned = self.kp0 if subindex == 1 else self.ki0
            band = self.safety.gain_band
            if gain > tuned * band or gain < tuned / band:
                raise ObjectRefused(ABORT_VALUE_TOO_HIGH if gain > tuned * band else ABORT_VALUE_TOO_LOW,
                                    f"gain outside [tuned/{band:g}, tuned*{band:g}] (boards/safety.py gain_band)")
            if subindex == 1:
                self.pi.kp = gain
            else:
                self.pi.ki = gain
        elif index == 0x2001 and 1 <= subindex <= 5:
            # takes effect at the next preset command (a running preset keeps its setpoint)
            self.preset_rates_arcsec_s[subindex] = value / 1000.0
        elif index == 0x2000 and subindex == 3:
            self.pi.u_max = self.u_max = q15_to_duty(value)
        elif index == 0x2000 and subindex == 4:
            try:
                self.counter_fraction = check_counter_fraction(q15_to_duty(value))
            except ValueError as exc:
                raise ObjectRefused(reason=str(exc)) from None
        else:
            super().od_write(index, subindex, value)
