"""Focus mechanism: stepper half-steps -> ball-screw position, LVDT, motor shaft encoder (paper §3.2, §3.3).

Kinematic model (stated simplification): every half-step commanded moves the housing by exactly
6.25 µm (0.9° per half-step, 1:2 belt, 5 mm/rev ball screw) at once; no motor dynamics, belt
stretch, screw backlash or LVDT nonlinearity. Half-steps are lost (counted in ``lost_halfsteps``)
only in two stated ways: beyond the ±5 mm travel limit, as a stalled stepper would lose them, and
by fault injection (:meth:`FocusPlant.stall`: the next *n* commanded half-steps do not move the
rotor, e.g. a jammed mechanism). No load- or rate-dependent pull-out is modelled.

The motor's incremental shaft encoder (§3.2: "The motor has a incremental shaft encoder"; four
full rotations and four index pulses over ±5 mm) turns with the rotor: counts =
floor(half-steps travelled / 400 × counts per rev), with ``motor_encoder_counts_per_rev`` = 2000
(assumed, see plant/parameters.yaml: 500 lines in x4 quadrature → 5 counts per half-step). It
counts only half-steps actually travelled, so a lost half-step shows as a 5-count deviation
between the firmware's commanded counter and the encoder.
"""

from __future__ import annotations

import math

from plant.params import FocusParameters

__all__ = ["FocusPlant"]


class FocusPlant:
    """Stepper-driven focus housing.

    Parameters
    ----------
    params : FocusParameters
        ``load_parameters().focus``.

    Attributes
    ----------
    halfsteps : int
        Net half-steps actually travelled since reset (position = halfsteps × 6.25 µm).
    lost_halfsteps : int
        Half-steps commanded but not travelled (against a travel limit, or stalled by
        :meth:`stall`).
    stall_halfsteps : int
        Commanded half-steps still to be lost by an injected stall (:meth:`stall`).
    index_pulses : int
        Index pulses seen so far (each crossing of an index position, either direction).
    power : str
        ``"on"``, ``"hold"`` (motor power off, regenerative hold, §5.2) or ``"free"`` (control
        power off). Kinematic model: steps are only accepted with ``"on"``; the position is kept in
        all modes (no gravity or vibration drift is modelled).
    """

    def __init__(self, params: FocusParameters) -> None:
        self.params = params
        self._m_per_step = params.metres_per_halfstep
        self._steps_per_rev = params.halfsteps_per_motor_rev
        self._limit_steps = int(math.floor(params.travel_m / self._m_per_step + 1e-9))
        self.now_us = 0
        self.reset()

    def reset(self, position_m: float = 0.0) -> None:
        """Place the housing at ``position_m`` (rounded to a half-step); clear counters, power on."""
        self.halfsteps = int(round(position_m / self._m_per_step))
        self.lost_halfsteps = 0
        self.stall_halfsteps = 0
        self.index_pulses = 0
        self.power = "on"

    def stall(self, n_halfsteps: int) -> None:
        """Fault injection: the next ``n_halfsteps`` commanded half-steps are lost (the rotor
        does not turn), as when the mechanism jams or the step rate exceeds the pull-out rate.

        Raises
        ------
        ValueError
            ``n_halfsteps`` < 0.
        """
        if int(n_halfsteps) < 0:
            raise ValueError(f"n_halfsteps must be >= 0, got {n_halfsteps}")
        self.stall_halfsteps += int(n_halfsteps)

    def set_power(self, mode: str) -> None:
        """Set ``"on"``, ``"hold"`` or ``"free"``.

        Raises
        ------
        ValueError
            Unknown mode.
        """
        if mode not in ("on", "hold", "free"):
            raise ValueError(f"focus power mode must be 'on', 'hold' or 'free', got {mode!r}")
        self.power = mode

    def step(self, n_halfsteps: int) -> None:
        """Apply ``n_halfsteps`` (signed) half-steps: the ``StepDir(on_step)`` port.

        Steps are ignored unless ``power == "on"``; steps past ±5 mm, and steps while an
        injected stall lasts (:meth:`stall`), are lost.
        """
        if self.power != "on" or n_halfsteps == 0:
            return
        if self.stall_halfsteps:
            k = min(self.stall_halfsteps, abs(int(n_halfsteps)))
            self.stall_halfsteps -= k
            self.lost_halfsteps += k
            n_halfsteps = int(n_halfsteps) - k * (1 if n_halfsteps > 0 else -1)
            if n_halfsteps == 0:
                return
        target = self.halfsteps + int(n_halfsteps)
        lim = self._limit_steps
        clamped = max(-lim, min(lim, target))
        self.lost_halfsteps += abs(target - clamped)
        before = self._index_number(self.halfsteps)
        self.halfsteps = clamped
        self.index_pulses += abs(self._index_number(clamped) - before)

    def advance_to(self, t_us: int) -> None:
        """Kinematic model: only records the time (kept for a uniform plant interface)."""
        self.now_us = int(t_us)

    def _index_number(self, halfsteps: int) -> int:
        # number of index positions (offset + k * 2.5 mm) at or below this position
        rev = (halfsteps * self._m_per_step - self.params.index_offset_m) / self.params.metres_per_motor_rev
        return math.floor(rev + 1e-9)

    @property
    def position_m(self) -> float:
        """Housing position [m], 0 = mid travel."""
        return self.halfsteps * self._m_per_step

    def lvdt_voltage_v(self) -> float:
        """Demodulated LVDT output [V]: centre + span · x / 5 mm (0–5 V over ±5 mm, assumed)."""
        p = self.params
        return p.lvdt_center_v + p.lvdt_span_v * self.position_m / p.travel_m

    def motor_encoder_counts(self) -> int:
        """Motor-shaft incremental encoder count [counts] (cumulative, signed, 0 at mid travel;
        ``motor_encoder_counts_per_rev`` per motor revolution, assumed 2000). The QEI port."""
        return math.floor(self.halfsteps / self._steps_per_rev * self.params.motor_encoder_counts_per_rev)

    def at_index(self) -> bool:
        """True when the motor shaft sits on an index mark (position = offset + k·2.5 mm)."""
        rev = (self.position_m - self.params.index_offset_m) / self.params.metres_per_motor_rev
        return abs(rev - round(rev)) * self._steps_per_rev < 0.5
