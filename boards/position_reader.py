"""EnDat position reader firmware (PIC18F4480), node 3 = RA, node 4 = DEC (paper §3.2-§3.3).

Every ``read_period_us`` (10 ms) the reader performs one EnDat exchange with the 29-bit RCN 829
on the axis shaft (:class:`boards.endat.EnDatMaster`), applies the alignment offset (maintenance
console, §5.2), checks the soft limits "on the telescope extremes" (§3.3) and publishes
POSITION. A frame failing the CRC is counted (``crc_errors``), not used (the last good position
is kept and POSITION flag bit2 is set) and reported with a FAULT frame (code 2) — at most one
such FAULT per second so a broken cable does not flood the bus.

RS232 telemetry (§3.4, optional ``serial_port``): each read is also one 10 ms telemetry sample
(position counts incl. offset, POSITION flags); a packet of 25 goes out every 250 ms.

Position convention
-------------------
``pos_counts`` = (raw word + offset) mod 2**29; the axis angle is that value read as a signed
29-bit number times 360°/2**29 (0.00241″ per count), i.e. −180° .. +180°. For RA it is the hour
angle once the offset is aligned (§5.2), for DEC the declination-axis angle.

Soft limits (assumed defaults, not in the paper)
------------------------------------------------
RA: −95° .. +95° hour angle (6 h 20 min either side of the meridian); DEC: −40° .. +110°
(axis angle). LIMIT frames are sent on every change of the flags and every 100 ms while any
flag is set (architecture.md); the axis controller lets a flag expire when they stop.

Braking zone (boards/safety.py): a limit flag is raised where braking must *begin* so that the
axis stops before the limit: when the distance to the limit in the direction of motion is at
most ``SafetyLimits.braking_distance_arcsec(v)``, v being the reader's rate estimate from two
successive EnDat reads (10 ms apart), or when the angle is at or past the limit. The flag
clears once the axis moves no faster than ``brake_stop_tol_arcsec_s`` toward the limit and is
back inside by ``hysteresis_arcsec`` (10″).
"""

from __future__ import annotations

from typing import Callable, Final, Optional

import can

from bus import protocol as proto
from boards.endat import POSITION_BITS, EnDatMaster
from boards.firmware_base import FAULT_CRC, Board
from boards.peripherals import Timer
from boards.services import ObjectRefused
from boards.services.application import ABORT_MAX_LESS_THAN_MIN
from boards.safety import DEFAULT_SAFETY, SafetyLimits
from bus.scheduler import PRIO_ISR, Scheduler
from bus.units import ARCSEC_PER_REV
from mypy_extensions import mypyc_attr

__all__ = ["PositionReader", "DEFAULT_LIMITS_DEG", "POS_LOW", "POS_HIGH", "POS_CRC", "POS_INVALID"]

COUNTS_PER_REV: Final = 1 << POSITION_BITS
ARCSEC_PER_COUNT: Final = ARCSEC_PER_REV / COUNTS_PER_REV

#: Assumed soft limits per axis (0 RA, 1 DEC), degrees of axis angle.
DEFAULT_LIMITS_DEG: Final = {0: (-95.0, 95.0), 1: (-40.0, 110.0)}

POS_LOW, POS_HIGH, POS_CRC, POS_INVALID = 0x01, 0x02, 0x04, 0x08
POS_LOW_NEAR, POS_HIGH_NEAR = 0x10, 0x20
LIMIT_LOW, LIMIT_HIGH, LIMIT_INVALID = 0x01, 0x02, 0x04
LIMIT_LOW_NEAR, LIMIT_HIGH_NEAR = 0x08, 0x10
CRC_FAULT_MIN_INTERVAL_US: Final = 1_000_000


@mypyc_attr(allow_interpreted_subclasses=True)   # compiled (bus/_native.py); may be subclassed
class PositionReader(Board):
    """PIC18F4480 EnDat position reader firmware.

    Parameters
    ----------
    scheduler, bus, name, serial_port
        As :class:`boards.firmware_base.Board`.
    node_id : int
        3 (RA) or 4 (DEC).
    read_position_word : callable
        Port: the encoder's raw 29-bit position word (counts, 0 .. 2**29 − 1).
    axis : int, optional
        0 RA, 1 DEC (default node_id − 3).
    read_period_us : int
        EnDat read and POSITION period, µs (10 000, assumed: matches the 10 ms samples of §3.4).
    low_limit_deg, high_limit_deg : float, optional
        Soft limits, degrees of axis angle (defaults :data:`DEFAULT_LIMITS_DEG`).
    hysteresis_arcsec : float
        A limit clears this far inside, arcsec.
    offset_counts : int
        Alignment offset added to the raw word, counts.
    limit_repeat_us : int
        LIMIT repeat period while active, µs (100 000).
    name : str, optional
        Owner name (default ``"reader-<node>"``; the network passes the registry name).
    serial_port : object, optional
        RS232 telemetry port with the pyserial ``write()`` API (None: no telemetry).
    safety : SafetyLimits
        Braking deceleration and reaction time of the braking zone (:mod:`boards.safety`).
    """

    DEVICE_TYPE = int(proto.DeviceType.POSITION_READER)
    KIND = "reader"
    CANOPEN_KIND = "position_reader"

    def __init__(self, scheduler: Scheduler, bus: can.BusABC, node_id: int = 3, *,
                 read_position_word: Callable[[], int], axis: Optional[int] = None,
                 read_period_us: int = 10_000, low_limit_deg: Optional[float] = None,
                 high_limit_deg: Optional[float] = None, hysteresis_arcsec: float = 10.0,
                 offset_counts: int = 0, limit_repeat_us: int = 100_000,
                 name: Optional[str] = None, serial_port=None,
                 safety: SafetyLimits = DEFAULT_SAFETY) -> None:
        self.safety = safety
        self.axis = (node_id - 3) if axis is None else int(axis)
        super().__init__(scheduler, bus, node_id, name=name,
                         background_period_us=read_period_us, serial_port=serial_port,
                         telemetry_period_us=read_period_us)
        self._position_cob = proto.position_cob_id(self.node_id)   # fixed: not per read
        lo, hi = DEFAULT_LIMITS_DEG.get(self.axis, (-180.0, 180.0))
        self.low_limit_deg = lo if low_limit_deg is None else float(low_limit_deg)
        self.high_limit_deg = hi if high_limit_deg is None else float(high_limit_deg)
        if not self.low_limit_deg < self.high_limit_deg:
            raise ValueError("low_limit_deg must be below high_limit_deg")
        self.hysteresis_arcsec = float(hysteresis_arcsec)
        self._near_deg = safety.braking_distance_arcsec(safety.max_rate_arcsec_s) / 3600.0
        self.read_period_us = int(read_period_us)
        self.limit_repeat_us = int(limit_repeat_us)
        self.offset_counts = int(offset_counts) % COUNTS_PER_REV
        self.endat = EnDatMaster(read_position_word)
        self.timer = self.add_timer(Timer(scheduler, self.read_period_us, self.isr_read,
                                          priority=PRIO_ISR, owner=f"{self.name}/isr"))
        self._init_reader_state()

    def _peripherals(self) -> list:
        return [self.endat]

    def _init_state(self) -> None:
        super()._init_state()
        if hasattr(self, "endat"):
            self._init_reader_state()

    def _init_reader_state(self) -> None:
        self.pos_counts = 0
        self.rate_arcsec_s = 0.0          # from two successive good reads
        self._prev_counts: Optional[int] = None
        self.have_position = False
        self.last_crc_error = False
        self.alarm = False
        self.limit_flags = 0
        self.near_flags = 0           # LIMIT_LOW/LIMIT_HIGH bits: inside the approach zone
        self._limit_sent_flags = 0
        self._limit_sent_us: Optional[int] = None
        self._crc_fault_us: Optional[int] = None
        self._send_limit = False

    # ------------------------------------------------------------------ API
    def report_counters(self) -> dict:
        """EnDat CRC errors (see :meth:`boards.firmware_base.Board.report_counters`)."""
        return {"crc_errors": self.endat.crc_errors}

    @property
    def crc_errors(self) -> int:
        """EnDat frames rejected since reset."""
        return self.endat.crc_errors

    def crc_error_count(self) -> int:
        return self.endat.crc_errors

    def flip_bit(self, n: int) -> None:
        """Fault injection: corrupt bit ``n`` of the next EnDat frame (see boards.endat)."""
        self.endat.flip_bit(n)

    def set_offset_counts(self, counts: int) -> None:
        """Alignment offset (maintenance console §5.2), counts added to the raw word."""
        self.offset_counts = int(counts) % COUNTS_PER_REV

    def set_offset_deg(self, degrees: float) -> None:
        """Alignment offset in degrees."""
        self.set_offset_counts(int(round(degrees * 3600.0 / ARCSEC_PER_COUNT)))

    @property
    def angle_deg(self) -> float:
        """Axis angle from the last good position, degrees (−180 .. 180)."""
        c = self.pos_counts
        if c >= COUNTS_PER_REV // 2:
            c -= COUNTS_PER_REV
        return c * ARCSEC_PER_COUNT / 3600.0

    def position_flags(self) -> int:
        """POSITION flags byte."""
        f = self.limit_flags & (POS_LOW | POS_HIGH)
        if self.near_flags & LIMIT_LOW:
            f |= POS_LOW_NEAR
        if self.near_flags & LIMIT_HIGH:
            f |= POS_HIGH_NEAR
        if self.last_crc_error:
            f |= POS_CRC
        if not self.have_position or self.alarm:
            f |= POS_INVALID
        return f

    def limit_frame_flags(self) -> int:
        """LIMIT flags byte."""
        f = self.limit_flags & (LIMIT_LOW | LIMIT_HIGH)
        if self.near_flags & LIMIT_LOW:
            f |= LIMIT_LOW_NEAR
        if self.near_flags & LIMIT_HIGH:
            f |= LIMIT_HIGH_NEAR
        if not self.have_position or self.alarm:
            f |= LIMIT_INVALID
        return f

    # ------------------------------------------------------------------ ISR (10 ms)
    def isr_read(self, now_us: int) -> None:
        """Timer ISR: one EnDat exchange, limits, queue POSITION (and LIMIT when due)."""
        r = self.endat.read()
        self.last_crc_error = not r.crc_ok
        if r.crc_ok:
            self.alarm = bool(r.f1 or r.f2)
            if not self.alarm:
                position = r.position
                assert position is not None            # a reading with a valid CRC has one
                self.pos_counts = (position + self.offset_counts) % COUNTS_PER_REV
                prev = self._prev_counts
                if prev is not None:
                    d = (self.pos_counts - prev + COUNTS_PER_REV // 2) % COUNTS_PER_REV - COUNTS_PER_REV // 2
                    self.rate_arcsec_s = d * ARCSEC_PER_COUNT * 1e6 / self.read_period_us
                self._prev_counts = self.pos_counts
                self.have_position = True
                self._update_limits()
        elif self._crc_fault_us is None or now_us - self._crc_fault_us >= CRC_FAULT_MIN_INTERVAL_US:
            self._crc_fault_us = now_us
            self.queue(proto.emcy_cob_id(self.node_id), None)
        pflags = self.position_flags()
        self.queue(self._position_cob,
                   proto.encode_position(pflags, min(self.crc_errors, 0xFFFF), self.pos_counts))
        if self.telemetry_enabled:
            self.telemetry_sample(now_us, (self.pos_counts, pflags))
        flags = self.limit_frame_flags()
        due = flags != self._limit_sent_flags or (
            flags and (self._limit_sent_us is None
                       or now_us - self._limit_sent_us >= self.limit_repeat_us))
        if due:
            self._limit_sent_flags = flags
            self._limit_sent_us = now_us
            self.queue(proto.limit_cob_id(self.node_id),
                       proto.encode_limit(self.axis, flags, self.pos_counts))

    def _update_limits(self) -> None:
        a = self.angle_deg
        h = self.hysteresis_arcsec / 3600.0
        sf = self.safety
        # a rate above twice the maximum commanded rate is a position jump, not motion (documented)
        cap = sf.max_zone_rate_arcsec_s
        v = max(-cap, min(cap, self.rate_arcsec_s))
        tol = sf.brake_stop_tol_arcsec_s
        f = self.limit_flags
        zone_lo = sf.braking_distance_arcsec(v) / 3600.0 if v < 0 else 0.0
        zone_hi = sf.braking_distance_arcsec(v) / 3600.0 if v > 0 else 0.0
        if a <= self.low_limit_deg + zone_lo:
            f |= LIMIT_LOW
        elif a > self.low_limit_deg + h and v > -tol:
            f &= ~LIMIT_LOW
        if a >= self.high_limit_deg - zone_hi:
            f |= LIMIT_HIGH
        elif a < self.high_limit_deg - h and v < tol:
            f &= ~LIMIT_HIGH
        self.limit_flags = f
        # approach zone: within the braking distance of the highest commanded rate; the axis
        # controller ramps its setpoint toward a limit there (boards/safety.py)
        near = self._near_deg
        n = self.near_flags
        if a <= self.low_limit_deg + near:
            n |= LIMIT_LOW
        elif a > self.low_limit_deg + near + h:
            n &= ~LIMIT_LOW
        if a >= self.high_limit_deg - near:
            n |= LIMIT_HIGH
        elif a < self.high_limit_deg - near - h:
            n &= ~LIMIT_HIGH
        self.near_flags = n

    def _background(self, now_us: int) -> None:
        queue = []
        for cob, data in self._tx_queue:
            if data is None:
                self.send_fault(FAULT_CRC, detail=self.endat.reads & 0xFFFF)
            else:
                queue.append((cob, data))
        self._tx_queue = queue
        if not self.last_crc_error:
            self.clear_fault(FAULT_CRC)        # EMCY error reset after a good read
        super()._background(now_us)

    # ------------------------------------------------------------------ CANopen objects (SDO)
    def od_read(self, index: int, subindex: int):
        """0x2100 soft limits (signed counts), 0x2101 encoder offset, 0x2102 CRC errors."""
        if index == 0x2100 and subindex in (1, 2):
            deg = self.low_limit_deg if subindex == 1 else self.high_limit_deg
            return int(round(deg * 3600.0 / ARCSEC_PER_COUNT))
        if index == 0x2101:
            return self.offset_counts
        if index == 0x2102:
            return self.endat.crc_errors
        return super().od_read(index, subindex)

    def od_write(self, index: int, subindex: int, value) -> None:
        """Soft limits (low must stay below high) and the alignment offset."""
        if index == 0x2100 and subindex in (1, 2):
            deg = value * ARCSEC_PER_COUNT / 3600.0
            lo = deg if subindex == 1 else self.low_limit_deg
            hi = deg if subindex == 2 else self.high_limit_deg
            if not lo < hi:
                raise ObjectRefused(ABORT_MAX_LESS_THAN_MIN, "low soft limit must be below high")
            self.low_limit_deg, self.high_limit_deg = lo, hi
        elif index == 0x2101:
            self.set_offset_counts(value)
        else:
            super().od_write(index, subindex, value)
