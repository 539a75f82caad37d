"""Axis velocity reader firmware: the friction-roller incremental encoder of one axis on its own node.

Nodes 0x0F (``VEL_RA``) and 0x11 (``VEL_DEC``), device type 0x09. The paper: "the motion is
sensed by an on-shaft absolute encoder and an incremental encoder coupled through a friction
roller" (§1); the roller "allows backlash-free accurate velocity measurements through a reduction
of 735:30 (or 1:24.5)" and the encoder is a 4.608 million ppr Gurley 8×60 (§2.2). The lab network
carried "position and velocity measurements for the two axes" (§3.4).

Why a board of its own (assumed; docs/protocol.md "Networks"): Fig. 5's "over sixteen
microcontroller boards" is not in the text; the boards the text names one per sensor — 2 axis
controllers, 2 EnDat readers, 4 motor tachometers, 2 auxiliary encoders, focus, display, dome,
weather, USB-to-CAN — are 15. A velocity node per axis for the friction-roller encoder (whose
quadrature lines the axis controller's QEI also receives, for its PI loop, §3.3) makes 17, "over
sixteen", and reads §3.4's lab list as one node per measurement. A network without these boards
loses nothing the PI loop needs.

Hardware (assumed: the paper names no part for it): a PIC18F4431 like the tachometers, QEI with
16-bit POSCNT (:class:`boards.peripherals.Qei` + the firmware's 32-bit extension).

Every 10 ms (timer ISR, :data:`bus.protocol.AXIS_VELOCITY_PERIOD_US`) the ISR reads POSCNT,
extends it, keeps the last :data:`bus.protocol.VEL_MAX_WINDOW_TICKS` ticks and queues one
``AXIS_VELOCITY``: the low 16 bits of the count and the axis rate over the shortest window of
:data:`WINDOWS_TICKS` (20 ms .. 1 s) holding at least :data:`MIN_COUNTS` counts
(:func:`boards.tachometer.speed_window`). With 1.129e8 counts/rev (0.01148″/count) the 15″/s
tracking rate moves 1306 counts/s: the 200 ms window (261 counts, 0.4 % resolution, 100 ms lag);
the 2°/s slew uses 20 ms (12 544 counts).
"""

from __future__ import annotations

from typing import Callable, ClassVar, Final, Optional

import can

from boards.tachometer import QeiSpeedBoard
from bus import protocol as proto
from bus.scheduler import Scheduler
from bus.units import ARCSEC_PER_REV
from mypy_extensions import mypyc_attr

__all__ = ["AxisVelocityReader", "WINDOWS_TICKS", "MIN_COUNTS"]

#: Candidate rate windows, 10 ms ticks (20 ms .. 1 s), shortest first (assumed, see module doc).
WINDOWS_TICKS: Final = (2, 5, 10, 20, 50, proto.VEL_MAX_WINDOW_TICKS)
#: Counts a window must hold before it is used (assumed: ≤ 0.4 % quantisation of the reading).
MIN_COUNTS: Final = 256


@mypyc_attr(allow_interpreted_subclasses=True)   # compiled (bus/_native.py); may be subclassed
class AxisVelocityReader(QeiSpeedBoard):
    """Friction-roller encoder velocity node (PIC18F4431 QEI).

    Parameters
    ----------
    scheduler, bus, name
        As :class:`boards.firmware_base.Board`.
    node_id : int
        0x0F (RA) or 0x11 (DEC).
    read_qei_counts : callable
        Port: the friction-roller encoder's cumulative signed count (the axis controller's QEI
        input, fanned out).
    qei_counts_per_rev : int
        Encoder counts per axis revolution (4.608e6 × 24.5, §2.2; parameter file
        ``axes.<axis>.encoders``).
    period_us : int
        ISR and ``AXIS_VELOCITY`` period, µs (10 000).
    serial_port : None
        No RS232 telemetry (the paper's RS232 set-up had the PI, position and focus boards);
        a port raises ValueError.
    """

    DEVICE_TYPE: ClassVar[int] = int(proto.DeviceType.AXIS_VELOCITY)
    KIND: ClassVar[str] = "velocity_reader"
    CANOPEN_KIND: ClassVar[str] = "velocity_reader"
    WINDOWS_TICKS: ClassVar[tuple] = WINDOWS_TICKS
    MIN_COUNTS: ClassVar[int] = MIN_COUNTS
    MAX_WINDOW_TICKS: ClassVar[int] = proto.VEL_MAX_WINDOW_TICKS
    NO_RS232: ClassVar[str] = "the axis velocity reader has no RS232 telemetry (paper §3.4: PI, position and focus boards)"

    def __init__(self, scheduler: Scheduler, bus: can.BusABC, node_id: int = int(proto.NodeId.VEL_RA), *,
                 read_qei_counts: Callable[[], int], qei_counts_per_rev: int,
                 period_us: int = proto.AXIS_VELOCITY_PERIOD_US, name: Optional[str] = None,
                 serial_port=None) -> None:
        super().__init__(scheduler, bus, node_id, read_counts=read_qei_counts,
                         counts_per_rev=qei_counts_per_rev, period_us=period_us, name=name,
                         serial_port=serial_port)

    @property
    def qei_counts_per_rev(self) -> int:
        """Encoder counts per axis revolution."""
        return self.counts_per_rev

    @property
    def arcsec_per_count(self) -> float:
        """Axis angle per encoder count [arcsec]."""
        return ARCSEC_PER_REV / self.counts_per_rev

    def _scale(self) -> float:
        return self.arcsec_per_count * 1e3 / (self.period_us * 1e-6)   # milli-″/s per count·tick

    def _status_cob_id(self, node_id: int) -> int:
        return proto.axis_velocity_cob_id(node_id)

    def _encode(self, window_ticks: int, counts: int, reading: int) -> bytes:
        return proto.encode_axis_velocity(window_ticks, counts, reading)

    @property
    def rate_marcsec_s(self) -> int:
        """Last axis rate estimate [milli-arcsec/s] (the AXIS_VELOCITY field)."""
        return self.reading

    @property
    def rate_arcsec_s(self) -> float:
        """Last axis rate estimate [arcsec/s]."""
        return self.reading * 1e-3

    def report_counters(self) -> dict:
        """Encoder resolution and the last reading (the report's board row)."""
        return {"qei_counts_per_rev": self.counts_per_rev, "qei_counts": self.qei.extended,
                "rate_arcsec_s": round(self.rate_arcsec_s, 3), "window_ticks": self.window_ticks}
