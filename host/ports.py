"""Plant ports: the callables a firmware's peripherals call to sample or drive the plant.

A port advances its plant to the scheduler's time first, so a sensor read at ``now_us`` sees the
plant at ``now_us`` (the plants integrate lazily, between the reads and writes of the boards).
:mod:`host.network` wires one per board port (its ``PORTS`` table). Compiled with the hot path
(``bus/_native.py``): the ports are called ≈ 3000 times per simulated second on the ``full``
network.
"""

from __future__ import annotations

from typing import Any

from bus.scheduler import Scheduler
from plant.axis import AxisPlant

__all__ = ["PlantPort", "AxisPlantPort"]


class PlantPort:
    """``fn(*fixed, *args)`` called after ``plant.advance_to(scheduler.now_us)``.

    Parameters
    ----------
    plant : object
        Anything with ``advance_to(t_us)``; if it also has ``now_us`` (µs), a call at the time the
        plant already has skips the (no-op) advance — a time in the past still reaches
        ``advance_to`` and raises there.
    scheduler : bus.scheduler.Scheduler
        The clock whose ``now_us`` the plant is advanced to.
    fn : callable
        The plant method (sensor read or actuator write).
    *fixed
        Leading arguments bound to ``fn`` (e.g. the motor ``"a"`` of a shunt voltage read).
    """

    def __init__(self, plant: Any, scheduler: Scheduler, fn: Any, *fixed: Any) -> None:
        self.plant = plant
        self.scheduler = scheduler
        self.fn = fn
        self.fixed = tuple(fixed)
        self.advance = plant.advance_to
        self.lazy = hasattr(plant, "now_us")      # knows its time: skip advancing to it again

    def __call__(self, *args: Any) -> Any:
        now_us = self.scheduler.now_us
        if not self.lazy or self.plant.now_us != now_us:
            self.advance(now_us)
        fn = self.fn           # a local: ``self.fn(...)`` compiles to a generic attribute lookup
        if self.fixed:
            return fn(*self.fixed, *args)
        return fn(*args)


class AxisPlantPort:
    """``fn(*args)`` called after ``plant.advance_to(scheduler.now_us)``, for an axis plant.

    :class:`PlantPort` for :class:`plant.axis.AxisPlant`, the plant of most ports (encoders,
    shunts, tachometers, auxiliary encoders, PWM). The plant is compiled too (``plant.axis``), so
    reading its time and advancing it are native calls here, not attribute lookups.

    Parameters
    ----------
    plant : plant.axis.AxisPlant
    scheduler : bus.scheduler.Scheduler
        The clock whose ``now_us`` the plant is advanced to.
    fn : callable
        The plant method (sensor read or actuator write), with any fixed leading argument already
        bound (``functools.partial(plant.shunt_voltage_v, "a")``).
    """

    def __init__(self, plant: AxisPlant, scheduler: Scheduler, fn: Any) -> None:
        self.plant = plant
        self.scheduler = scheduler
        self.fn = fn

    def __call__(self, *args: Any) -> Any:
        now_us = self.scheduler.now_us
        plant = self.plant
        if plant.now_us != now_us:          # a time in the past still reaches advance_to (raises)
            plant.advance_to(now_us)
        fn = self.fn           # a local: ``self.fn(...)`` compiles to a generic attribute lookup
        return fn(*args)
