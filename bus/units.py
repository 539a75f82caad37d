"""Units and shared constants: the one place each is defined.

A leaf module: it imports only :mod:`math`, so every package may import it — ``plant`` included
(the one module of ``bus`` that ``plant`` imports; docs/architecture.md). Values are exact
definitions or paper numbers, never tuned.
"""

from __future__ import annotations

import math

__all__ = ["ARCSEC_PER_REV", "ARCSEC_PER_RAD", "Q15_FULL_SCALE", "duty_to_q15", "q15_to_duty",
           "COUNTER_FRACTION_MAX", "check_counter_fraction", "TICK_US"]

#: Arc seconds in one revolution (360 × 3600), exact.
ARCSEC_PER_REV = 1_296_000.0
#: Arc seconds per radian (648000/π), exact to double precision.
ARCSEC_PER_RAD = 648_000.0 / math.pi
#: Q15 full scale: a duty of ±1 (±100 %) is ±32767 in frames and firmware (paper §3.4 frames are
#: 16-bit signed; docs/protocol.md).
Q15_FULL_SCALE = 32767
#: The axis controllers' control tick [µs] (paper §3.3/§4: Δt = 5 ms).
TICK_US = 5_000
#: Largest counter-torque fraction p of the twin-motor drive law, exclusive: at p = 1 both motors
#: cancel and the axis cannot be driven (paper §3.3 uses 0.10–0.25).
COUNTER_FRACTION_MAX = 1.0


def duty_to_q15(duty: float) -> int:
    """Duty (−1..1, saturated) to Q15 (±:data:`Q15_FULL_SCALE`), rounded to nearest."""
    q = int(round(duty * Q15_FULL_SCALE))
    return -Q15_FULL_SCALE if q < -Q15_FULL_SCALE else (Q15_FULL_SCALE if q > Q15_FULL_SCALE else q)


def q15_to_duty(q15: int) -> float:
    """Q15 count to duty (±1 at ±:data:`Q15_FULL_SCALE`)."""
    return q15 / float(Q15_FULL_SCALE)


def check_counter_fraction(p: float, where: str = "counter_fraction") -> float:
    """Return ``p`` as float if ``0 <= p < COUNTER_FRACTION_MAX``.

    Raises
    ------
    ValueError
        Out of range (the message names ``where`` and the valid range).
    """
    p = float(p)
    if not 0.0 <= p < COUNTER_FRACTION_MAX:
        raise ValueError(f"{where} must be in [0, {COUNTER_FRACTION_MAX:g}), got {p}")
    return p
