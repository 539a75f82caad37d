"""The PDO gate of one CANopen node: process data only in NMT OPERATIONAL (CiA 301 §7.3.2).

A TPDO the firmware sends leaves the node only while it is powered and OPERATIONAL (otherwise it
is dropped and counted); a received RPDO is acted on only then (otherwise counted). The state is
read, not copied: the device's ``powered`` flag and its canopen NMT slave's ``_state`` (the
heartbeat byte, 5 = OPERATIONAL) are the single source, so no NMT transition can leave the gate
behind.

Compiled (``bus/_native.py``): the gate is on the path of every PDO a board sends or receives
(≈ 3.5 % of the ``full`` network's instructions while it ran interpreted, docs/performance.md).
:class:`boards.services.device.CanopenDevice` builds it and keeps its ``transmit_pdo`` /
``accept_rpdo`` API; the firmware (:class:`boards.firmware_base.Board`) calls the gate directly.
Nothing here reads the wall clock, sleeps or starts a thread.
"""

from __future__ import annotations

from typing import Any, Callable, Final, Iterable

from mypy_extensions import mypyc_attr

__all__ = ["PdoGate", "NMT_OPERATIONAL"]

#: canopen's NMT state code of OPERATIONAL (the heartbeat's state byte, CiA 301 Table 51).
NMT_OPERATIONAL: Final = 5


@mypyc_attr(allow_interpreted_subclasses=True)   # tests build deliberately broken gates
class PdoGate:
    """The NMT gate on a node's process data.

    Parameters
    ----------
    device : object
        The owner, with a ``powered`` flag (bool).
    nmt : object
        Its canopen NMT slave, whose ``_state`` is the NMT state code.
    transmit : callable
        ``transmit(cob_id: int, data: bytes)``: queue a frame on the board's CAN controller.
    tpdo_ids : iterable of int
        The node's TPDO COB-IDs (its EDS).

    Attributes
    ----------
    pdos_sent, pdos_suppressed : int
        TPDOs sent / dropped because the node was not OPERATIONAL.
    rpdos_ignored : int
        RPDOs received outside OPERATIONAL (not acted on).
    """

    def __init__(self, device: Any, nmt: Any, transmit: Callable[[int, bytes], None],
                 tpdo_ids: Iterable[int], name: str = "") -> None:
        self.device = device
        self.nmt = nmt
        self.transmit = transmit
        self.tpdo_ids: frozenset[int] = frozenset(tpdo_ids)
        self.name = name
        self.pdos_sent = 0
        self.pdos_suppressed = 0
        self.rpdos_ignored = 0

    def is_open(self) -> bool:
        """True while process data passes: the node is powered and NMT OPERATIONAL."""
        return bool(self.device.powered) and self.nmt._state == NMT_OPERATIONAL

    def transmit_pdo(self, cob_id: int, data: bytes) -> bool:
        """Send a TPDO if the gate is open; otherwise drop it (counted). Returns True if sent.

        Raises
        ------
        ValueError
            If ``cob_id`` is not one of this node's TPDO COB-IDs (an emulator bug).
        """
        if cob_id not in self.tpdo_ids:
            raise ValueError(f"{self.name}: 0x{cob_id:03X} is not a TPDO of this node "
                             f"({sorted(hex(i) for i in self.tpdo_ids)})")
        if not (bool(self.device.powered) and self.nmt._state == NMT_OPERATIONAL):
            self.pdos_suppressed += 1
            return False
        self.transmit(cob_id, bytes(data))
        self.pdos_sent += 1
        return True

    def accept_rpdo(self) -> bool:
        """True if a received PDO may be acted on now (the gate is open); else counted."""
        if bool(self.device.powered) and self.nmt._state == NMT_OPERATIONAL:
            return True
        self.rpdos_ignored += 1
        return False
