"""Firmware safety limits: the documented bounds every board command is checked against.

This is the parameter file of the firmware's safety behaviour (docs/faults.md lists every
fault and reaction). None of these numbers is in the paper; each is an assumption with its
reason below. ``boards/`` never imports ``plant/``: host wiring passes a :class:`SafetyLimits`
(or keeps the defaults) to :class:`boards.axis_controller.AxisController` and
:class:`boards.position_reader.PositionReader`.

Braking strategy (STOP, STOP_ALL, limit stop, watchdog stop, reader loss)
--------------------------------------------------------------------------
The setpoint ramps from the measured rate to zero at :attr:`SafetyLimits.brake_decel_arcsec_s2`
and the PI tracks the ramp. A supervisor compares the measured rate with the ramp every tick:
if |ω| exceeds |ramp| + :attr:`~SafetyLimits.brake_margin_arcsec_s` for
:attr:`~SafetyLimits.brake_bad_ticks` consecutive ticks (the axis is not slowing down: gains too
low or wrong, drive saturated), the firmware cuts both PWM duties to zero (the H-bridges then
short the armatures: dynamic braking) and reports FAULT ``BRAKE_CUT``; the cut holds until
the next motion command. So a stop does not depend on the PI gains.

Soft limits
-----------
The position reader raises a LIMIT flag not at the limit but where braking must begin: when
the distance to the limit in the direction of motion is at most
``v²/(2·a) + |v|·brake_latency_us + hysteresis`` (v = the reader's own rate estimate from two
successive EnDat reads, a = the braking deceleration). So the axis stops *before* the limit at
any rate whose braking distance the drive can achieve (tests/test_boards_safety.py checks it at
slew on the full plant).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final, Optional

from bus.protocol import VELOCITY_MAX_MARCSEC_S

__all__ = ["SafetyLimits", "DEFAULT_SAFETY", "RECOMMENDED_HOST_WATCHDOG_US",
           "REFUSE_GAIN", "REFUSE_RATE", "REFUSE_DUTY", "REFUSE_LIMIT", "REFUSE_READER",
           "REFUSE_TRAVEL", "REFUSE_AZIMUTH"]

#: Reason codes of FAULT ``COMMAND_REFUSED`` (detail = reason << 8 | command code).
REFUSE_GAIN, REFUSE_RATE, REFUSE_DUTY, REFUSE_READER, REFUSE_TRAVEL = 1, 2, 3, 5, 6
#: Reason 4: motion toward an active soft limit (issue 10: was FAULT LIMIT_STOP with detail =
#: command, the second meaning of code 4).
REFUSE_LIMIT: Final = 4
#: Reason 7 (issue 12, dome): a GOTO azimuth outside 0 .. 359.99° (centi-degrees 0 .. 35999).
REFUSE_AZIMUTH: Final = 7

#: Host watchdog: the host sends its CiA heartbeat (0x710) every second, so 2 s = two missed host
#: heartbeats (assumed; CiA-301 practice is a consumer time of 1.5-3 heartbeat periods). The
#: default of :attr:`SafetyLimits.host_watchdog_us`.
RECOMMENDED_HOST_WATCHDOG_US: Final = 2_000_000


@dataclass(frozen=True)
class SafetyLimits:
    """Bounds and supervision times of the firmware (all assumed, reasons per field).

    Attributes
    ----------
    max_rate_arcsec_s : float
        Highest rate a VELOCITY command may ask, ″/s; faster is refused (REFUSE_RATE). Default
        10 800 = 3°/s: the paper ran the axes closed loop at 1–3°/s (§4, ref. 18), so the slew
        preset of Table 1 (2°/s) is not the axis's limit. Issue 11 asked for "rates within the
        slew rate"; we bound at the highest rate the paper reports operating instead, because a
        limit below a documented operating point would refuse the paper's own test.
    gain_band : float
        SET_KP/SET_KI accept gains in [tuned / band, tuned × band] around the gains the board
        was built with (default 4: a factor 4 either way covers the spread between the low and
        high preload σ2 of Table 2 (×≈3) and still refuses the gains that, measured in issue 11,
        stop TRACK (×1e4) or remove braking (0)).
    brake_decel_arcsec_s2 : float
        Braking ramp, ″/s² (default 14 400: slew 2°/s to rest in 0.5 s; needs ≈120 N·m at the
        RA axis (J = 1760 kg·m², §4), a few % of the twin drive's stall torque).
    brake_margin_arcsec_s : float
        Supervisor margin above the ramp, ″/s (default 1500: the PI's tracking lag of the ramp,
        ≈ decel × 0.1 s, plus one QEI count noise; measured lag at default gains < 300″/s).
    brake_bad_ticks : int
        Consecutive 5 ms ticks above ramp + margin before the duty cut (default 4 = 20 ms).
    brake_grace_us : int
        After the ramp has reached zero, the axis must be below ``brake_stop_tol_arcsec_s``
        within this time or the duty is cut, µs (default 200 000: several closed-loop time
        constants, τc ≈ 10 ms for the SIMC gains of docs/boards.md).
    max_zone_rate_arcsec_s : float
        The reader's braking zone uses its rate estimate capped at this, ″/s (default 21 600 =
        twice ``max_rate_arcsec_s``, the highest commanded rate: a larger estimate from two reads
        10 ms apart is a position jump, e.g. an offset change, not motion).
    overspeed_factor : float
        An axis measured faster than this × ``max_rate_arcsec_s`` (any mode, e.g. OPEN_LOOP at full
        duty) for ``brake_bad_ticks`` consecutive ticks is braked to rest and FAULT OVERSPEED
        is sent (default 1.5: above the PI's ≈20 % overshoot of a slew step (docs/boards.md),
        inside the 2 × maximum rate the reader's braking zone is computed for). Found by the 10⁶-frame
        fuzz: open loop at full duty ran DEC 0.36° past its limit.
    brake_rest_us : int
        The rate must stay below ``brake_stop_tol_arcsec_s`` this long before a braking stop
        counts as done and the PI holds zero rate, µs (default 50 000 = 10 ticks: an unstable
        loop passing through zero is not at rest; a hold that moves faster than the tolerance
        restarts the supervised stop; found by the fuzz: gains at the band edge oscillated at
        full duty, ±270″/s, in STOP).
    brake_stop_tol_arcsec_s : float
        Rate below which the axis counts as stopped, ″/s (default 50: ≈ 20 QEI counts per 5 ms
        tick, well above the quantisation of 2.3″/s, below the 100″/s guide rate).
    brake_latency_us : int
        Reaction time budget of the soft-limit zone, µs (default 40 000: one 10 ms EnDat read,
        one 5 ms ISR, the PI's ramp lag, bus latency; the slew test shows the margin left).
    host_watchdog_us : int or None
        Stop the axis when no host frame (its CiA heartbeat 0x710, an AXIS_COMMAND to
        this axis, STOP_ALL; NMT and SDO traffic do not count) arrived for this long, µs. Armed by the
        first host frame after reset (boards boot before the PC, paper §5.2 power-on; an idle bus
        with no host raises nothing). None = disabled. Default
        :data:`RECOMMENDED_HOST_WATCHDOG_US` (2 s).
    reader_timeout_us : int
        Position reader declared lost after this long without a POSITION frame, µs (default
        50 000 = 5 POSITION periods of 10 ms). Supervision starts with the reader's first frame.
    limit_expiry_us : int
        An active LIMIT flag expires this long after the last LIMIT frame, µs (default 350 000
        = 3.5 repeat periods of 100 ms: tolerates two lost frames).
    fault_clear_hold_us : int
        A fault condition counts as cleared after being absent this long; only then is
        FAULT_CLEARED sent and a new occurrence reported (rate limit), µs (default 1 s).
    """

    max_rate_arcsec_s: float = VELOCITY_MAX_MARCSEC_S / 1000.0     # 10 800 ″/s, the DBC's range
    gain_band: float = 4.0
    brake_decel_arcsec_s2: float = 14_400.0
    brake_margin_arcsec_s: float = 1_500.0
    brake_bad_ticks: int = 4
    brake_latency_us: int = 40_000
    brake_grace_us: int = 200_000
    max_zone_rate_arcsec_s: float = 21_600.0
    overspeed_factor: float = 1.5
    brake_stop_tol_arcsec_s: float = 50.0
    brake_rest_us: int = 50_000
    host_watchdog_us: Optional[int] = RECOMMENDED_HOST_WATCHDOG_US
    reader_timeout_us: int = 50_000
    limit_expiry_us: int = 350_000
    fault_clear_hold_us: int = 1_000_000

    def __post_init__(self) -> None:
        if not 1.0 <= self.overspeed_factor < float("inf"):
            raise ValueError(f"overspeed_factor must be >= 1, got {self.overspeed_factor}")
        if not self.gain_band >= 1.0:
            raise ValueError(f"gain_band must be >= 1, got {self.gain_band}")
        for name in ("max_rate_arcsec_s", "brake_decel_arcsec_s2", "brake_margin_arcsec_s",
                     "brake_stop_tol_arcsec_s", "max_zone_rate_arcsec_s"):
            v = getattr(self, name)
            if not (v > 0 and v < float("inf")):
                raise ValueError(f"{name} must be finite and > 0, got {v}")
        for name in ("brake_bad_ticks", "brake_latency_us", "brake_grace_us", "brake_rest_us", "reader_timeout_us",
                     "limit_expiry_us", "fault_clear_hold_us"):
            if int(getattr(self, name)) <= 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if self.host_watchdog_us is not None and int(self.host_watchdog_us) <= 0:
            raise ValueError(f"host_watchdog_us must be > 0 or None, got {self.host_watchdog_us}")

    def braking_distance_arcsec(self, rate_arcsec_s: float) -> float:
        """Distance covered from ``rate_arcsec_s`` to rest, reaction time included, arcsec."""
        v = abs(rate_arcsec_s)
        return v * v / (2.0 * self.brake_decel_arcsec_s2) + v * self.brake_latency_us * 1e-6


DEFAULT_SAFETY: Final = SafetyLimits()
