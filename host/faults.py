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

from boards.registry import BOARDS, CANOPEN_KINDS
from boards.registry import board as registry_board

__all__ = ["FaultKind", "FAULTS", "FAULT_KINDS", "FAULT_PARAMS", "check_fault", "inject"]

#: Optional parameters a fault entry may carry (scenario ``faults[]`` keys besides at_s/kind/board).
FAULT_PARAMS = ("bit", "halfsteps", "ids", "probability", "count", "duration_s", "arbitration_id",
                "auto_recover")
#: Parameters of the CAN-level faults (host/bus_faults.py), passed through as keyword arguments.
_BUS_PARAMS = ("ids", "probability", "count", "duration_s", "arbitration_id", "auto_recover")


@dataclass(frozen=True)
class FaultKind:
    """One row of the fault table.

    Attributes
    ----------
    apply : callable(tel, fault, now_us)
        Injects the fault into the running network.
    board_kinds : tuple of str or None
        Registry kinds (``boards.registry``) the fault applies to; ``None`` = any board.
    board : str
        ``"required"``, ``"optional"`` (absent = every node, e.g. corrupt any sender's frames) or
        ``"none"`` (the fault is not about one board: the host or the bus).
    sim_bus : bool
        Needs the emulated CAN bus model (``bus.interface: sim``): error frames, TEC/REC and
        bus-off are modelled there, not on vcan0/can0.
    needs : tuple of str
        Parameters (of :data:`FAULT_PARAMS`) the entry must give.
    allows : tuple of str
        Parameters it may give (``needs`` included).
    doc : str
        What it does (docs/scenarios.md).
    """

    apply: Callable
    board_kinds: tuple[str, ...] | None = None
    board: str = "required"
    sim_bus: bool = False
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


def _bus_fault(kind: str) -> Callable:
    """A CAN-level fault of :mod:`host.bus_faults` as a table function (board and given
    parameters passed through)."""
    from host import bus_faults

    fn = bus_faults.FAULT_KINDS[kind]

    def apply(tel, fault, now_us: int) -> None:
        kw = {name: getattr(fault, name) for name in _BUS_PARAMS if getattr(fault, name, None) is not None}
        if fault.board is not None:
            kw["board"] = fault.board
        fn(tel, now_us, **kw)

    apply.__name__ = f"_{kind}"
    return apply


_WINDOW = ("ids", "probability", "count", "duration_s")

#: kind -> FaultKind. The scenario schema's ``faults[].kind`` names are these keys.
FAULTS: dict[str, FaultKind] = {
    "endat_bit_flip": FaultKind(_endat_bit_flip, ("position_reader",), allows=("bit",),
                                doc="flip one bit of the next EnDat transfer (CRC error, counted)"),
    # not the USB gateway: it decodes no CAN frames (its malformed input is an OUT report)
    "malformed_frame": FaultKind(_malformed_frame, CANOPEN_KINDS,
                                 doc="the host sends the board a short frame with a wrong device type"),
    "board_reset": FaultKind(_board_reset, doc="watchdog reset: the board boots again"),
    "remove_board": FaultKind(_remove_board, doc="power the board off for the rest of the run"),
    "focus_stall": FaultKind(_focus_stall, ("focus_controller",), needs=("halfsteps",), allows=("halfsteps",),
                             doc="the focus plant loses half-steps; the firmware must notice"),
    # CAN fault confinement (ISO 11898-1, bus/network.py) and lost nodes: host/bus_faults.py
    "can_error": FaultKind(_bus_fault("can_error"), board="optional", sim_bus=True, allows=_WINDOW,
                           doc="frames (of `ids`, from `board` if given) meet bit errors: error frames, "
                               "TEC/REC, automatic retransmission"),
    "frame_loss": FaultKind(_bus_fault("frame_loss"), board="optional", sim_bus=True, allows=_WINDOW,
                            doc="`board` (or every node) misses frames of `ids` without an error signalled"),
    "babbling_node": FaultKind(_bus_fault("babbling_node"), board="none", sim_bus=True,
                               allows=("arbitration_id", "duration_s"),
                               doc="a node sends `arbitration_id` back to back; higher ids wait"),
    "bus_off": FaultKind(_bus_fault("bus_off"), sim_bus=True, allows=("auto_recover",),
                         doc="the board's CAN controller is driven to bus-off (TEC > 255)"),
    "host_loss": FaultKind(_bus_fault("host_loss"), board="none", sim_bus=True, allows=("duration_s",),
                           doc="every frame the host sends is lost (the host goes silent)"),
    "reader_loss": FaultKind(_bus_fault("reader_loss"), ("position_reader",),
                             doc="the position reader loses power: no POSITION/LIMIT frames"),
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
    if board is None:
        if fk.board == "required":
            raise ValueError(f"{kind} needs board: one of {', '.join(_names_of_kinds(fk.board_kinds) if fk.board_kinds else BOARDS)}")
    elif fk.board == "none":
        raise ValueError(f"{kind} is not about one board: leave out board (got {board})")
    if board is None:
        spec = None
    else:
        spec, _ = registry_board(board)
    if spec is not None and fk.board_kinds is not None and spec.kind not in fk.board_kinds:
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
        tel.client.logs.error(now_us, fault.board or "bus", "injected-fault", fault.kind)
