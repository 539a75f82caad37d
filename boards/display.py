"""Digital display unit firmware, node 0x0C (issue 12; paper §3.4: "digital display unit" among
the 10 nodes tested in the lab; the paper gives no layout, so the screen is assumed).

It listens to the bus only: the readers' POSITION (0x183, 0x184, its RPDO1/2) and the axis
controllers' AXIS_STATUS (0x181, 0x182, RPDO3/4), and every ``refresh_period_us`` (250 ms) writes
one screen to its 7-segment/character-LCD driver (:class:`boards.peripherals.CharacterDisplay`),
whose port the host logs as one line of ``display.log`` per refresh. The screen::

    HA +01:23:45.6 DEC +29:22:00 dHA +15.04"/s dDEC +0.00"/s RA TRACK DEC STOP

* HA: the RA reader's position read as a signed 29-bit angle (the hour angle once aligned,
  :mod:`boards.position_reader`), in hours, minutes, seconds of time (0.1 s);
* DEC: the DEC reader's position, in degrees, arc-minutes, arc-seconds;
* dHA, dDEC: the axis rates in ″/s, from the difference of the two POSITION frames last shown,
  over the time between their arrivals (0.00241″ per count: over a 250 ms refresh ≈ 0.01″/s);
* RA/DEC: the axis modes from AXIS_STATUS byte 1.

An input older than ``stale_timeout_us`` (1 s) is shown as dashes and flagged in
``DISPLAY_STATUS`` (TPDO1, 0x18C, every 1 s: flags, frames received, refreshes).

The display shows the hour angle, not the right ascension: it has no clock for the local
sidereal time (RA = LST − HA), and the paper names none.
"""

from __future__ import annotations

from typing import Callable, Final, Optional

import can

from boards.firmware_base import Board
from boards.peripherals import CharacterDisplay, Timer
from bus import protocol as proto
from bus.scheduler import PRIO_ISR, Scheduler
from bus.units import ARCSEC_PER_REV
from mypy_extensions import mypyc_attr

__all__ = ["DisplayUnit", "format_hms", "format_dms", "STALE_TEXT"]

_POS_REV: Final = 1 << 29
_ARCSEC_PER_POS_COUNT: Final = ARCSEC_PER_REV / _POS_REV
_POSITION_INVALID: Final = int(proto.PositionFlags.INVALID)    # a plain int: tested for every frame
STALE_TEXT: Final = {"ha": "--:--:--.-", "dec": "---:--:--", "rate": "------", "mode": "----"}


def format_hms(hours: float) -> str:
    """``+HH:MM:SS.S`` of a signed angle in hours (rounded to 0.1 s of time)."""
    sign = "-" if hours < 0 else "+"
    tenths = int(round(abs(hours) * 36_000))
    h, rem = divmod(tenths, 36_000)
    m, rem = divmod(rem, 600)
    return f"{sign}{h:02d}:{m:02d}:{rem // 10:02d}.{rem % 10}"


def format_dms(degrees: float) -> str:
    """``+DD:MM:SS`` of a signed angle in degrees (rounded to 1″)."""
    sign = "-" if degrees < 0 else "+"
    secs = int(round(abs(degrees) * 3600))
    d, rem = divmod(secs, 3600)
    m, s = divmod(rem, 60)
    return f"{sign}{d:02d}:{m:02d}:{s:02d}"


def _signed(counts: int) -> int:
    return counts - _POS_REV if counts >= _POS_REV // 2 else counts


@mypyc_attr(allow_interpreted_subclasses=True)   # compiled (bus/_native.py); may be subclassed
class DisplayUnit(Board):
    """Digital display unit firmware.

    Parameters
    ----------
    scheduler, bus, name, serial_port
        As :class:`boards.firmware_base.Board` (no telemetry).
    node_id : int
        0x0C.
    on_show : callable(text) or None
        Port: every screen written (the host's ``display.log``).
    refresh_period_us : int
        Screen refresh period, µs (plant/parameters.yaml ``display``, 250 ms assumed).
    stale_timeout_us : int
        Inputs older than this are shown as dashes, µs (1 s assumed).
    status_period_us : int
        DISPLAY_STATUS period (a multiple of the refresh period), µs.
    """

    DEVICE_TYPE = int(proto.DeviceType.DISPLAY)
    KIND = "display"
    CANOPEN_KIND = "display"

    def __init__(self, scheduler: Scheduler, bus: can.BusABC, node_id: int = int(proto.NodeId.DISPLAY), *,
                 on_show: Optional[Callable[[str], None]] = None, refresh_period_us: int = 250_000,
                 stale_timeout_us: int = 1_000_000, status_period_us: int = proto.DISPLAY_STATUS_PERIOD_US,
                 name: Optional[str] = None, serial_port=None) -> None:
        if status_period_us % refresh_period_us:
            raise ValueError("status_period_us must be a multiple of refresh_period_us")
        super().__init__(scheduler, bus, node_id, name=name, background_period_us=refresh_period_us)
        self.refresh_period_us = int(refresh_period_us)
        self.stale_timeout_us = int(stale_timeout_us)
        self.status_every = int(status_period_us) // self.refresh_period_us
        self.lcd = CharacterDisplay(on_show)
        self.timer = self.add_timer(Timer(scheduler, self.refresh_period_us, self.isr_refresh,
                                          priority=PRIO_ISR, owner=f"{self.name}/isr"))
        self._pos_ids = {proto.position_cob_id(n): i for i, n in enumerate(proto.READER_NODES)}
        self._axis_ids = {proto.axis_status_cob_id(n): i for i, n in enumerate(proto.AXIS_NODES)}
        for cob in (*self._pos_ids, *self._axis_ids):
            self.accept_id(cob)
        self._init_display_state()

    def _peripherals(self) -> list:
        return [self.lcd]

    def _init_state(self) -> None:
        super()._init_state()
        if hasattr(self, "lcd"):
            self._init_display_state()

    def _init_display_state(self) -> None:
        self._pos: list = [None, None]        # (pos_counts, t_us) latest
        self._shown: list = [None, None]      # (pos_counts, t_us) at the last refresh
        self._rate: list = [None, None]       # ″/s shown at the last refresh
        self._mode: list = [None, None]       # (AxisMode, t_us)
        self.frames_received = 0
        self.refreshes = 0
        self.flags = 0

    def report_counters(self) -> dict:
        """Frames consumed, refreshes and the last screen (report board row)."""
        return {"frames_received": self.frames_received, "refreshes": self.refreshes,
                "screen": self.lcd.text}

    # ------------------------------------------------------------------ receive
    def handle_frame(self, arbitration_id: int, data: bytes) -> None:
        now = self.scheduler.now_us
        i = self._pos_ids.get(arbitration_id)
        if i is not None:
            p = proto.decode_position(data)
            self.frames_received += 1
            if not p.flags & _POSITION_INVALID:
                self._pos[i] = (p.pos_counts, now)
            return
        i = self._axis_ids.get(arbitration_id)
        if i is not None:
            s = proto.decode_axis_status(data)
            self.frames_received += 1
            self._mode[i] = (s.mode, now)
            return
        super().handle_frame(arbitration_id, data)

    # ------------------------------------------------------------------ refresh ISR
    def isr_refresh(self, now_us: int) -> None:
        """Compute and write one screen; every ``status_every`` refreshes queue DISPLAY_STATUS."""
        fresh = [p is not None and now_us - p[1] <= self.stale_timeout_us for p in self._pos]
        mode_fresh = [m is not None and now_us - m[1] <= self.stale_timeout_us for m in self._mode]
        for i in (0, 1):
            p, s = self._pos[i], self._shown[i]
            if fresh[i] and s is not None and p[1] > s[1]:
                d = (p[0] - s[0] + _POS_REV // 2) % _POS_REV - _POS_REV // 2
                self._rate[i] = d * _ARCSEC_PER_POS_COUNT / ((p[1] - s[1]) * 1e-6)
            elif not fresh[i]:
                self._rate[i] = None
            self._shown[i] = p if fresh[i] else None
        ha = (format_hms(_signed(self._pos[0][0]) * _ARCSEC_PER_POS_COUNT / 54_000.0) if fresh[0]
              else STALE_TEXT["ha"])
        dec = (format_dms(_signed(self._pos[1][0]) * _ARCSEC_PER_POS_COUNT / 3600.0) if fresh[1]
               else STALE_TEXT["dec"])
        rates = [f"{r:+.2f}" if r is not None else STALE_TEXT["rate"] for r in self._rate]
        modes = [proto.AxisMode(self._mode[i][0]).name if mode_fresh[i] else STALE_TEXT["mode"] for i in (0, 1)]
        self.lcd.show(f"HA {ha} DEC {dec} dHA {rates[0]}\"/s dDEC {rates[1]}\"/s RA {modes[0]} DEC {modes[1]}")
        self.refreshes += 1
        f = 0
        for bit, ok in zip((proto.DisplayFlags.RA_POSITION_STALE, proto.DisplayFlags.DEC_POSITION_STALE,
                            proto.DisplayFlags.RA_AXIS_STALE, proto.DisplayFlags.DEC_AXIS_STALE),
                           (*fresh, *mode_fresh)):
            if not ok:
                f |= int(bit)
        self.flags = f
        if self.refreshes % self.status_every == 0:
            self.queue(proto.display_status_cob_id(self.node_id),
                       proto.encode_display_status(f, self.frames_received, self.refreshes))

    # ------------------------------------------------------------------ CANopen objects (SDO)
    def od_read(self, index: int, subindex: int):
        """0x2300 refresh period, stale timeout (ms) and frames received."""
        if index == 0x2300:
            return {1: self.refresh_period_us // 1000, 2: self.stale_timeout_us // 1000,
                    3: self.frames_received & 0xFFFFFFFF}.get(subindex)
        return super().od_read(index, subindex)
