"""Fault injection: one table from fault kind to the function that injects it.

A scenario's ``faults[]`` entries (``{at_s, kind, board, **params}``) are validated against this
table when the scenario loads (kind, which board kinds it applies to, which parameters it needs
or allows) and applied at their simulated time by :func:`inject`. Adding a fault = one function
here + one :class:`FaultKind` row in :data:`FAULTS` + its row in docs/scenarios.md; the scenario
schema's ``kind`` names come from this table.

Fault functions run in simulated time on the scheduler (priority ``PRIO_HOST``); they act on
the built network (``host.network.Telescope``) only through board methods, the host client or
the plant — never through a board's private state.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from boards.registry import BOARDS
from boards.registry import board as registry_board

__all__ = ["FaultKind", "FAULTS", "FAULT_KINDS", "FAULT_PARAMS", "check_fault", "inject"]

#: Optional parameters a fault entry may carry (scenario ``faults[]`` keys besides at_s/kind/board).
FAULT_PARAMS = ("bit", "halfsteps")


@dataclass(frozen=True)
class FaultKind:
    """One row of the fault table.

    Attributes
    ----------
    apply : callable(tel, fault, now_us)
        Injects the fault into the running network.
    board_kinds : tuple of str or None
        Registry kinds (``boards.registry``) the fault applies to; ``None`` = any board.
    needs : tuple of str
        Parameters (of :data:`FAULT_PARAMS`) the entry must give.
    allows : tuple of str
        Parameters it may give (``needs`` included).
    doc : str
        What it does (docs/scenarios.md).
    """

    apply: Callable
    board_kinds: tuple[str, ...] | None = None
    needs: tuple[str, ...] = ()
    allows: tuple[str, ...] = ()
    doc: str = ""


def _endat_bit_flip(tel, fault, now_us: int) -> None:
    tel.boards[fault.board].endat.flip_bit(fault.bit if fault.bit is not None else 0)


def _malformed_frame(tel, fault, now_us: int) -> None:
    spec, inst = registry_board(fault.board)
    cob = spec.accepts(inst.node_id)[-1][0]  # its own command frame (its SDO request id if none)
    # a frame with the wrong device type byte and a short DLC: the board must count it
    tel.client.send_raw(cob, bytes([0xEE, 0x42, 0x00]), fault.board)


def _board_reset(tel, fault, now_us: int) -> None:
    tel.boards[fault.board].reset("watchdog")  # a running board boots again by itself


def _remove_board(tel, fault, now_us: int) -> None:
    tel.boards[fault.board].power_off()  # firmware stops, no frames; the host notices missing heartbeats
    tel.removed.add(fault.board)


def _focus_stall(tel, fault, now_us: int) -> None:
    tel.focus_plant.advance_to(now_us)
    tel.focus_plant.stall(fault.halfsteps)  # the plant loses steps; the firmware must notice


#: kind -> FaultKind. The scenario schema's ``faults[].kind`` names are these keys.
FAULTS: dict[str, FaultKind] = {
    "endat_bit_flip": FaultKind(_endat_bit_flip, ("position_reader",), allows=("bit",),
                                doc="flip one bit of the next EnDat transfer (CRC error, counted)"),
    "malformed_frame": FaultKind(_malformed_frame, doc="the host sends the board a short frame with a wrong device type"),
    "board_reset": FaultKind(_board_reset, doc="watchdog reset: the board boots again"),
    "remove_board": FaultKind(_remove_board, doc="power the board off for the rest of the run"),
    "focus_stall": FaultKind(_focus_stall, ("focus_controller",), needs=("halfsteps",), allows=("halfsteps",),
                             doc="the focus plant loses half-steps; the firmware must notice"),
}
FAULT_KINDS: tuple[str, ...] = tuple(FAULTS)


def check_fault(kind: str, board: str, params: dict) -> None:
    """Check a fault entry against the table.

    Raises
    ------
    ValueError
        The board's kind does not take this fault, or a parameter is missing or not allowed
        (the message names the kind, the board and what was expected).
    """
    fk = FAULTS[kind]
    spec, _ = registry_board(board)
    if fk.board_kinds is not None and spec.kind not in fk.board_kinds:
        raise ValueError(f"{kind} needs board: {' or '.join(_names_of_kinds(fk.board_kinds))}, not {board}")
    for name in fk.needs:
        if params.get(name) is None:
            raise ValueError(f"{kind} needs {name}")
    for name, value in params.items():
        if value is not None and name not in fk.allows:
            raise ValueError(f"{name} is not a parameter of kind {kind}")


def _names_of_kinds(kinds: tuple[str, ...]) -> list[str]:
    return [name for name, (spec, _) in BOARDS.items() if spec.kind in kinds]


def inject(tel, fault, now_us: int) -> None:
    """Apply one scenario fault to the running network and log it in ``errors.log``."""
    FAULTS[fault.kind].apply(tel, fault, now_us)
    if tel.client.logs:
        tel.client.logs.error(now_us, fault.board, "injected-fault", fault.kind)
