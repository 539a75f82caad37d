"""Fault kinds of issue 11 as functions on a built :class:`host.network.Telescope`.

A table ``FAULT_KINDS`` maps a scenario fault kind to ``fn(tel, now_us, **params)``; it is
meant to be merged into the scenario's fault table (host/scenario.py ``Fault.kind`` and
``Telescope.inject_fault``) by the issue-8 refactor — nothing here touches the scenario schema.
Every function only uses public APIs of ``bus.network.CanNetwork`` (docs/faults.md) and of the
boards, so the wiring is one line per kind.

========== ============================================ ==============================================
kind       parameters                                   effect
========== ============================================ ==============================================
can_error  board (sender, optional), ids, probability,  frames meet errors on the wire: error frames,
           count, duration_s                            TEC/REC, retransmission (ISO 11898-1)
frame_loss board (receiver, optional), ids, probability, receivers miss the frames (no error signalled)
           count, duration_s
babbling_  arbitration_id (default 0x001), duration_s   a node sends one id back to back; everything
node                                                    with a higher id waits
bus_off    board, auto_recover (default False)          the board's controller is driven to bus-off
host_loss  duration_s (optional)                        every frame the host sends is lost to all
                                                        boards (the host goes silent)
reader_    board (a reader)                             the reader loses power: no POSITION/LIMIT
loss
========== ============================================ ==============================================
"""

from __future__ import annotations

from typing import Callable, Dict

__all__ = ["FAULT_KINDS", "apply_fault"]


def _end(now_us: int, duration_s) -> int | None:
    return None if duration_s is None else now_us + int(round(float(duration_s) * 1e6))


def _bus_of(tel, board):
    return None if board is None else tel.boards[board].can.bus


def can_error(tel, now_us, *, board=None, ids=None, probability=1.0, count=None, duration_s=None):
    return tel.network.inject_errors(kind="corrupt", ids=ids, sender=_bus_of(tel, board),
                                     probability=probability, count=count, start_us=now_us,
                                     end_us=_end(now_us, duration_s))


def frame_loss(tel, now_us, *, board=None, ids=None, probability=1.0, count=None, duration_s=None):
    rx = None if board is None else [_bus_of(tel, board)]
    return tel.network.inject_errors(kind="loss", ids=ids, receivers=rx, probability=probability,
                                     count=count, start_us=now_us, end_us=_end(now_us, duration_s))


def babbling_node(tel, now_us, *, arbitration_id=0x001, duration_s=None):
    return tel.network.babble(arbitration_id, start_us=now_us, end_us=_end(now_us, duration_s))


def bus_off(tel, now_us, *, board, auto_recover=False):
    return tel.network.drive_bus_off(_bus_of(tel, board), auto_recover=auto_recover)


def host_loss(tel, now_us, *, duration_s=None):
    return tel.network.inject_errors(kind="loss", sender=tel.host_can_bus, start_us=now_us,
                                     end_us=_end(now_us, duration_s))


def reader_loss(tel, now_us, *, board):
    from boards.position_reader import PositionReader

    reader = tel.boards[board]
    if not isinstance(reader, PositionReader):
        raise ValueError(f"reader_loss needs a position reader board, not {board!r}")
    reader.power_off()


FAULT_KINDS: Dict[str, Callable] = {
    "can_error": can_error, "frame_loss": frame_loss, "babbling_node": babbling_node,
    "bus_off": bus_off, "host_loss": host_loss, "reader_loss": reader_loss,
}


def apply_fault(tel, kind: str, now_us: int, **params):
    """Apply fault ``kind`` now; raises ValueError for an unknown kind (listing the valid ones)."""
    try:
        fn = FAULT_KINDS[kind]
    except KeyError:
        raise ValueError(f"unknown fault kind {kind!r}; valid: {sorted(FAULT_KINDS)}") from None
    return fn(tel, now_us, **params)
