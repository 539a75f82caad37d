"""Exceptions of schmidt-fil: one base class and a few kinds.

Every error raised on purpose by schmidt-fil code derives from :class:`SchmidtFilError`, so a
caller can catch "anything the emulator complained about" in one clause, and the kinds below
tell configuration mistakes, bus trouble, simulation failures and host timeouts apart.

Firmware never raises into the bus: a board catches :class:`MalformedFrame`, counts it and
answers with a status bit or a ``FAULT`` frame. The scheduler never swallows an exception from
a callback: it stops the run with :class:`SimulationError` naming the owner and the time.
"""

from __future__ import annotations

__all__ = [
    "SchmidtFilError",
    "ConfigurationError",
    "BusError",
    "FrameError",
    "MalformedFrame",
    "EncodeError",
    "SimulationError",
    "HostTimeout",
]


class SchmidtFilError(Exception):
    """Base class of every schmidt-fil error."""


class ConfigurationError(SchmidtFilError):
    """A scenario, parameter or wiring mistake detected before or while building a run."""


class BusError(SchmidtFilError):
    """Trouble on the emulated CAN bus or a serial link (detached bus, bad frame id, ...)."""


class FrameError(BusError):
    """A frame field that does not fit the protocol (base of decode and encode errors).

    Parameters
    ----------
    frame : str
        Frame name, e.g. ``"AXIS_STATUS"`` (see ``bus.protocol.frame_name``).
    field : str
        Offending field, e.g. ``"dlc"``, ``"device_type"``, ``"mode"``.
    expected : str
        What the protocol requires, in words, e.g. ``"8 bytes"`` or ``"AxisMode 0..8"``.
    got : object, optional
        The value actually found.
    """

    def __init__(self, frame: str, field: str, expected: str, got: object = None) -> None:
        super().__init__(frame, field, expected, got)
        self.frame = frame
        self.field = field
        self.expected = expected
        self.got = got

    def __str__(self) -> str:
        text = f"{self.frame}: field {self.field!r} expected {self.expected}"
        if self.got is not None:
            text += f", got {self.got!r}"
        return text


class MalformedFrame(FrameError):
    """A received frame does not decode: wrong DLC, wrong device type or enum out of range.

    Boards catch this, increment ``malformed_frames`` and carry on.
    """


class EncodeError(FrameError, ValueError):
    """A value handed to an encoder cannot be sent (invalid enum, non-integer field).

    Deliberately *not* a :class:`MalformedFrame`: a board's ``except MalformedFrame`` must not
    hide a bug in the sender.
    """


class SimulationError(SchmidtFilError):
    """A callback failed inside the scheduler, or the scheduler was misused.

    Parameters
    ----------
    message : str
        Human-readable description.
    owner : str, optional
        Owner of the failing event (``Event.owner``), e.g. ``"ra-axis"``.
    now_us : int, optional
        Simulated time of the failure, µs.

    Notes
    -----
    When wrapping a callback's exception the original is kept as ``__cause__``.
    """

    def __init__(self, message: str, owner: str | None = None, now_us: int | None = None) -> None:
        super().__init__(message)
        self.owner = owner
        self.now_us = now_us


class HostTimeout(SchmidtFilError, TimeoutError):
    """The host waited (in simulated time) for an answer that did not come."""
