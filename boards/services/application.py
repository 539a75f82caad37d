"""What a board's firmware implements so the CANopen services can serve its objects.

The firmware keeps owning its variables (one source): the services never store a value of the
manufacturer area, they ask the firmware on every SDO read and hand every SDO write to the
firmware, which validates it and applies it or refuses it. The data type and the EDS range
(LowLimit/HighLimit of :mod:`bus.eds.objects`) are checked *before* ``od_write`` is called, so
the firmware sees only in-range values of the right type and checks what a range cannot say
(e.g. low soft limit < high soft limit).
"""

from __future__ import annotations

from typing import Final, Optional, Union

from canopen.sdo import SdoAbortedError
from mypy_extensions import mypyc_attr

__all__ = ["Application", "ObjectRefused", "ABORT_VALUE_INVALID", "ABORT_VALUE_TOO_HIGH",
           "ABORT_VALUE_TOO_LOW", "ABORT_MAX_LESS_THAN_MIN", "ABORT_DEVICE_STATE",
           "ABORT_NO_DATA", "ABORT_PARAMETER_INCOMPATIBLE"]

#: SDO abort codes (CiA 301 Table 22) the services and firmwares use.
ABORT_VALUE_INVALID: Final = 0x06090030          # invalid value for parameter
ABORT_VALUE_TOO_HIGH: Final = 0x06090031
ABORT_VALUE_TOO_LOW: Final = 0x06090032
ABORT_MAX_LESS_THAN_MIN: Final = 0x06090036
ABORT_PARAMETER_INCOMPATIBLE: Final = 0x06040043
ABORT_DEVICE_STATE: Final = 0x08000022           # not possible in the present device state
ABORT_NO_DATA: Final = 0x08000024

Value = Union[int, str]


class ObjectRefused(SdoAbortedError):
    """Raised by :meth:`Application.od_write` to refuse a value; becomes an SDO abort.

    Parameters
    ----------
    code : int
        The SDO abort code sent (default 0x06090030, invalid value).
    reason : str
        Why, for logs and the conformance report.
    """

    def __init__(self, code: int = ABORT_VALUE_INVALID, reason: str = "") -> None:
        super().__init__(code)
        self.reason = reason

    def __str__(self) -> str:
        base = super().__str__()
        return f"{base}: {self.reason}" if self.reason else base


@mypyc_attr(allow_interpreted_subclasses=True)   # compiled (bus/_native.py); boards subclass it
class Application:
    """The firmware side of the service interface (override what the board has; all optional).

    A board passes an object with these methods to :class:`boards.services.CanopenDevice`.
    """

    def od_read(self, index: int, subindex: int) -> Optional[Value]:
        """Current value of a firmware-owned object, in the EDS unit; None if not the firmware's
        (the services then answer from the object dictionary's default)."""
        return None

    def od_write(self, index: int, subindex: int, value: Value) -> None:
        """Apply a written value (already type- and range-checked) or raise :class:`ObjectRefused`
        leaving the state unchanged. The default refuses (0x08000022)."""
        raise ObjectRefused(ABORT_DEVICE_STATE, f"0x{index:04X}:{subindex} is not writable here")

    def nmt_changed(self, old: str, new: str) -> None:
        """The NMT state changed (names as canopen: 'PRE-OPERATIONAL', 'OPERATIONAL', 'STOPPED').
        RPDOs are not processed outside OPERATIONAL, so a board with motion should stop it when
        leaving OPERATIONAL (docs/canopen.md)."""

    def reset_application(self) -> None:
        """NMT reset node: restore the manufacturer objects to their power-on values (a processor
        reset). The services then reset communication and boot (once, even if this reset
        re-booted them)."""

    def heartbeat_event(self, node_id: int, lost: bool) -> None:
        """A consumed heartbeat (0x1016) timed out (``lost``) or came back."""
