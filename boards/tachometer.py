"""Motor tachometer firmware: the CP-850 incremental encoder on one DC motor shaft (paper §3.2).

Nodes 6..9 (``TACH_RA_1``, ``TACH_RA_2``, ``TACH_DEC_1``, ``TACH_DEC_2``; motor 1 = motor A, which
drives the positive direction, motor 2 = motor B), device type 0x04. The paper says each motor
"is coupled to a CP-850 incremental encoder which functions as a digital tachometer" and that the
lab network carried "velocity measurements for the four DC motors" (§3.4); §5.2's maintenance
console shows the tachometer readings and, with the axis velocity, the gear reduction at run time.

Hardware (assumed: the paper names no microcontroller for this board): a PIC18F4431, the part the
focus controller uses for its motor encoder, whose motion-feedback module has a quadrature
encoder interface (16-bit POSCNT). Modelled with :class:`boards.peripherals.Qei` (16-bit
register + the firmware's 32-bit software extension).

Every 5 ms (timer ISR, :data:`bus.protocol.TACH_STATUS_PERIOD_US`; the axis controllers' tick,
§3.3) the ISR reads POSCNT, extends it, stores the count in a ring of the last
:data:`bus.protocol.TACH_MAX_WINDOW_TICKS` ticks and queues one ``TACH_STATUS``: the low 16 bits of
the count (the host differences counts over any window it likes) and a speed estimate.

Speed estimate (documented choice, not from the paper): the count difference over the shortest
window of :data:`WINDOWS_TICKS` (20 ms .. 1 s) that holds at least :data:`MIN_COUNTS` counts,
i.e. a resolution of at most 1/16 of the reading once the window holds 16 counts, with a lag of
half the window. With 4000 counts/rev (the parameter file's assumed CP-850 resolution) a 2°/s
slew (8000 counts/s at the motor) uses the 20 ms window (160 counts: 0.6 % resolution); the
15″/s tracking rate (16.7 counts/s at the motor) needs the full 1 s window and still holds only
≈17 counts (6 % resolution). No count in 1 s is reported as speed 0 with window 200 ticks.

Not modelled: the encoder's line errors and index pulse, QEI noise filters, the count direction
of a mirrored mounting (the count follows the motor angle of the plant).
"""

from __future__ import annotations

import math
from typing import Callable, ClassVar, Final, List, Optional, Tuple

import can

from boards.firmware_base import Board
from boards.peripherals import Qei, Timer
from bus import protocol as proto
from bus.scheduler import PRIO_ISR, Scheduler
from mypy_extensions import mypyc_attr

__all__ = ["Tachometer", "QeiSpeedBoard", "WINDOWS_TICKS", "MIN_COUNTS", "speed_window"]

#: Candidate speed windows, 5 ms ticks (20 ms .. 1 s), shortest first (assumed, see module doc).
WINDOWS_TICKS: Final = (4, 10, 20, 50, 100, proto.TACH_MAX_WINDOW_TICKS)
#: Counts a window must hold before it is used (assumed: 1/16 quantisation of the reading).
MIN_COUNTS: Final = 16


def speed_window(ring: List[int], head: int, filled: int, windows_ticks: Tuple[int, ...],
                 min_counts: int) -> Tuple[int, int]:
    """The firmware's adaptive speed window: ``(w, d)``, the shortest window ``w`` of
    ``windows_ticks`` (ticks, shortest first) over which the count changed by at least
    ``min_counts``, and that change ``d`` [counts]; the longest window the ring holds otherwise
    (``w = 0`` before the second tick). ``ring``: a circular buffer of the extended counts of
    the last ticks (a list, as the firmware's RAM array), ``head`` the index of the newest,
    ``filled`` how many entries hold counts (1..len(ring)). Shared by the tachometers and the
    axis velocity readers (boards/velocity_reader.py)."""
    size = len(ring)
    c = ring[head]
    n = filled - 1
    w, d = n, 0
    for w in windows_ticks:
        if w > n:
            w = n
            d = c - ring[(head - n) % size] if n else 0
            break
        d = c - ring[(head - w) % size]
        if abs(d) >= min_counts:
            break
    return w, d


@mypyc_attr(allow_interpreted_subclasses=True)   # compiled (bus/_native.py); may be subclassed
class QeiSpeedBoard(Board):
    """A board that counts one incremental encoder in its QEI and, every ISR tick, queues its
    TPDO1 with the adaptive-window speed (:func:`speed_window`): the common firmware of the
    motor tachometers and the axis velocity readers (boards/velocity_reader.py).

    Subclasses set :attr:`WINDOWS_TICKS`, :attr:`MIN_COUNTS`, :attr:`MAX_WINDOW_TICKS`,
    :attr:`NO_RS232` (the ValueError text for a serial port), :meth:`_scale` (reading units per
    count per tick), :meth:`_status_cob_id` and :meth:`_encode`.

    Parameters
    ----------
    scheduler, bus, node_id, name
        As :class:`boards.firmware_base.Board`.
    read_counts : callable
        Port: the encoder's cumulative signed count.
    counts_per_rev : int
        Encoder counts per revolution (> 0, ValueError otherwise).
    period_us : int
        ISR and TPDO period, µs.
    serial_port : None
        These boards have no RS232 telemetry; a port raises ValueError.
    """

    WINDOWS_TICKS: ClassVar[tuple] = ()
    MIN_COUNTS: ClassVar[int] = 1
    MAX_WINDOW_TICKS: ClassVar[int] = 1
    NO_RS232: ClassVar[str] = "this board has no RS232 telemetry"

    def __init__(self, scheduler: Scheduler, bus: can.BusABC, node_id: int, *,
                 read_counts: Callable[[], int], counts_per_rev: int, period_us: int,
                 name: Optional[str] = None, serial_port=None) -> None:
        if serial_port is not None:
            raise ValueError(self.NO_RS232)
        if int(counts_per_rev) <= 0:
            raise ValueError(f"counts_per_rev must be > 0, got {counts_per_rev}")
        super().__init__(scheduler, bus, node_id, name=name, background_period_us=period_us)
        self._status_cob = self._status_cob_id(self.node_id)   # fixed: not per tick
        self.counts_per_rev = int(counts_per_rev)
        self.period_us = int(period_us)
        self.qei = Qei(read_counts)
        self.qei.reset()            # power-on: POSCNT cleared (the count is relative to power-on)
        self._per_count_tick = self._scale()
        self.timer = self.add_timer(Timer(scheduler, self.period_us, self.isr_tick, priority=PRIO_ISR,
                                          owner=f"{self.name}/isr"))
        self._init_speed_state()

    def _scale(self) -> float:
        raise NotImplementedError

    def _status_cob_id(self, node_id: int) -> int:
        raise NotImplementedError

    def _encode(self, window_ticks: int, counts: int, reading: int) -> bytes:
        raise NotImplementedError

    def _peripherals(self) -> list:
        return [self.qei]

    def _init_state(self) -> None:
        super()._init_state()
        if hasattr(self, "qei"):
            self._init_speed_state()

    def _init_speed_state(self) -> None:
        # the last MAX_WINDOW_TICKS + 1 extended counts, a circular buffer (newest at _ring_head)
        self._ring: List[int] = [0] * (self.MAX_WINDOW_TICKS + 1)
        self._ring_head = -1
        self._ring_filled = 0
        # the class's rule as instance attributes, read natively by the compiled ISR
        self._windows_ticks: Tuple[int, ...] = tuple(self.WINDOWS_TICKS)
        self._min_counts: int = self.MIN_COUNTS
        self.reading = 0            # last speed estimate, in the frame's integer unit
        self.window_ticks = self.MAX_WINDOW_TICKS
        self.frames_queued = 0

    # ------------------------------------------------------------------ ISR
    def isr_tick(self, now_us: int) -> None:
        """Timer ISR: read the QEI, update the speed estimate, queue the TPDO1."""
        self.qei.read_delta()
        c = self.qei.extended
        ring = self._ring
        head = (self._ring_head + 1) % len(ring)
        ring[head] = c
        self._ring_head = head
        if self._ring_filled < len(ring):
            self._ring_filled += 1
        w, d = speed_window(ring, head, self._ring_filled, self._windows_ticks, self._min_counts)
        if w == 0:
            self.reading, self.window_ticks = 0, 1
        else:
            self.reading = int(round(d * self._per_count_tick / w))
            self.window_ticks = w
        self.frames_queued += 1
        self.queue(self._status_cob, self._encode(self.window_ticks, c, self.reading))

    # ------------------------------------------------------------------ CANopen objects (SDO)
    def od_read(self, index: int, subindex: int):
        """0x2300 encoder counts per revolution."""
        if index == 0x2300:
            return self.counts_per_rev
        return super().od_read(index, subindex)


@mypyc_attr(allow_interpreted_subclasses=True)   # compiled (bus/_native.py); may be subclassed
class Tachometer(QeiSpeedBoard):
    """CP-850 motor tachometer firmware (PIC18F4431 QEI).

    Parameters
    ----------
    scheduler, bus, name, serial_port
        As :class:`boards.firmware_base.Board` (no RS232 telemetry: the paper's RS232 set-up
        had the PI, position and focus boards only; a port is refused).
    node_id : int
        6..9.
    read_motor_counts : callable
        Port: the motor encoder's cumulative signed count.
    counts_per_rev : int
        Encoder counts per motor revolution (parameter file ``axes.<axis>.tachometer``).
    period_us : int
        ISR and ``TACH_STATUS`` period, µs (5000).
    """

    DEVICE_TYPE: ClassVar[int] = int(proto.DeviceType.TACHOMETER)
    KIND: ClassVar[str] = "tachometer"
    CANOPEN_KIND: ClassVar[str] = "tachometer"
    WINDOWS_TICKS: ClassVar[tuple] = WINDOWS_TICKS
    MIN_COUNTS: ClassVar[int] = MIN_COUNTS
    MAX_WINDOW_TICKS: ClassVar[int] = proto.TACH_MAX_WINDOW_TICKS
    NO_RS232: ClassVar[str] = "the tachometer has no RS232 telemetry (paper §3.4: PI, position and focus boards)"

    def __init__(self, scheduler: Scheduler, bus: can.BusABC, node_id: int = 6, *,
                 read_motor_counts: Callable[[], int], counts_per_rev: int,
                 period_us: int = proto.TACH_STATUS_PERIOD_US, name: Optional[str] = None,
                 serial_port=None) -> None:
        super().__init__(scheduler, bus, node_id, read_counts=read_motor_counts,
                         counts_per_rev=counts_per_rev, period_us=period_us, name=name,
                         serial_port=serial_port)

    def _scale(self) -> float:
        return 2.0 * math.pi / self.counts_per_rev * 1e6 / (self.period_us * 1e-6)   # µrad/s per count·tick

    def _status_cob_id(self, node_id: int) -> int:
        return proto.tach_status_cob_id(node_id)

    def _encode(self, window_ticks: int, counts: int, reading: int) -> bytes:
        return proto.encode_tach_status(window_ticks, counts, reading)

    @property
    def speed_urad_s(self) -> int:
        """Last speed estimate of the motor shaft [µrad/s] (the TACH_STATUS field)."""
        return self.reading

    @property
    def speed_rad_s(self) -> float:
        """Last speed estimate [rad/s] of the motor shaft."""
        return self.reading * 1e-6

    def report_counters(self) -> dict:
        """Encoder resolution and the last reading (the report's board row)."""
        return {"counts_per_rev": self.counts_per_rev, "qei_counts": self.qei.extended,
                "speed_rad_s": round(self.speed_rad_s, 6), "window_ticks": self.window_ticks}
