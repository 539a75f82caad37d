"""schmidt-fil ``bus``: simulated time, the emulated CAN bus, the frame protocol and serial links.

Importing ``bus`` registers the python-can interface ``"schmidt-sim"`` (see
:mod:`bus.simbus`) so ``can.Bus(interface="schmidt-sim", channel="telescope")`` works even when
the package is not installed (installed, the ``can.interface`` entry point does the same).
"""

from __future__ import annotations

from bus._native import install_source_finder

install_source_finder()          # SCHMIDT_FIL_NATIVE=0: the .py source, not the compiled hot path

# ruff: noqa: E402
from bus.errors import (  # noqa: F401  (re-exported)
    BusError,
    ConfigurationError,
    EncodeError,
    FrameError,
    HostTimeout,
    MalformedFrame,
    SchmidtFilError,
    SimulationError,
)
from bus.scheduler import (  # noqa: F401
    PRIO_BACKGROUND,
    PRIO_CAN,
    PRIO_HOST,
    PRIO_ISR,
    PRIO_PLANT,
    Event,
    Scheduler,
)

INTERFACE_NAME = "schmidt-sim"


def _register_can_interface() -> None:
    """Add ``schmidt-sim`` to python-can's interface table (idempotent).

    python-can 4.6 looks an interface up in ``can.interfaces.BACKENDS`` (name -> (module,
    class)) and ``can.util.load_config`` first checks the name against the frozenset
    ``VALID_INTERFACES``, copied at import time into ``can``, ``can.interfaces`` and
    ``can.util``; all four are updated here.
    """
    import can
    import can.interfaces
    import can.util

    can.interfaces.BACKENDS[INTERFACE_NAME] = ("bus.simbus", "SimBus")
    if INTERFACE_NAME not in can.interfaces.VALID_INTERFACES:
        valid = frozenset(sorted(set(can.interfaces.VALID_INTERFACES) | {INTERFACE_NAME}))
        for module in (can.interfaces, can.util, can):
            if hasattr(module, "VALID_INTERFACES"):
                module.VALID_INTERFACES = valid


_register_can_interface()
