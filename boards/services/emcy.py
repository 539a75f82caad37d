"""EMCY producer with the error register (0x1001) and the pre-defined error field (0x1003).

Frame (CiA 301 §7.2.7.3.1), on 0x080 + node: b0–1 error code u16, b2 error register (0x1001),
b3–7 manufacturer-specific: b3 the project's fault code, b4–5 detail u16, b6–7 occurrences of
this error since reset (u16, saturating). The codes, register bits and whether an error is a
*condition* (active until cleared) or an *event* (one frame) are in
:data:`bus.eds.objects.EMCY_CODES`.

* A condition sends one EMCY when it becomes active (not again while it stays active) and an
  "error reset" EMCY (code 0x0000) when it clears; in that frame b2 is the register of the
  errors still active, b3 the cleared error's fault code and b4–5 the cleared error code.
* An event sends one EMCY; it never enters the active set (no error reset follows).
* Every EMCY (not the resets) is recorded in 0x1003 (newest at sub-index 1, 8 kept).
* In NMT STOPPED no EMCY is sent (CiA 301 §7.3.2.2.1); the error is still recorded and counted
  in ``suppressed``.

canopen's :class:`canopen.emcy.EmcyProducer` builds and sends the frames; what it lacks (the
register, the history, condition/event bookkeeping) is here.
"""

from __future__ import annotations

from collections import deque
from typing import Callable, Deque, Dict, Tuple

from canopen.emcy import EmcyProducer

from bus.eds.objects import EMCY_CODES, ERR_GENERIC, EmcyCode

__all__ = ["EmcyService", "HISTORY_LENGTH"]

HISTORY_LENGTH = 8


class EmcyService:
    """Error bookkeeping and EMCY transmission of one node.

    Parameters
    ----------
    producer : canopen.emcy.EmcyProducer
        The node's EMCY producer (already associated with its network).
    gate : callable
        ``gate() -> bool``: EMCY may be sent now (False in NMT STOPPED).
    """

    def __init__(self, producer: EmcyProducer, gate: Callable[[], bool]) -> None:
        self.producer = producer
        self._gate = gate
        self._init_state()

    def _init_state(self) -> None:
        self.active: Dict[str, Tuple[EmcyCode, int]] = {}
        self.history: Deque[int] = deque(maxlen=HISTORY_LENGTH)
        self.counts: Dict[str, int] = {}
        self.sent = 0
        self.suppressed = 0

    def reset(self) -> None:
        """Application reset: no active errors, empty history, counters zero (nothing is sent)."""
        self._init_state()

    @property
    def error_register(self) -> int:
        """0x1001: bit 0 while any condition is active, plus the conditions' class bits."""
        reg = 0
        for code, _ in self.active.values():
            reg |= ERR_GENERIC | code.register_bits
        return reg

    def is_active(self, name: str) -> bool:
        """True while condition ``name`` is active."""
        return name in self.active

    def report(self, name: str, detail: int = 0) -> bool:
        """An error occurred: a condition becomes active, or an event happened.

        Parameters
        ----------
        name : str
            A key of :data:`bus.eds.objects.EMCY_CODES`.
        detail : int
            The project's detail value (u16; larger values are masked).

        Returns
        -------
        bool
            True if an EMCY frame went out (False: condition already active, or NMT STOPPED).

        Raises
        ------
        KeyError
            For an unknown name (an emulator bug, not a bus input).
        """
        code = EMCY_CODES[name]
        if code.condition and name in self.active:
            return False
        n = self.counts.get(name, 0) + 1
        self.counts[name] = n
        if code.condition:
            self.active[name] = (code, detail)
            register = self.error_register
        else:
            register = self.error_register | ERR_GENERIC | code.register_bits
        self.history.appendleft(code.code | (code.fault_code << 16))
        return self._send(code.code, register, code.fault_code, detail, min(n, 0xFFFF))

    def clear(self, name: str) -> bool:
        """Condition ``name`` is gone: send the error reset (code 0x0000). No-op if not active."""
        if name not in self.active:
            return False
        code, _ = self.active.pop(name)
        return self._send(0x0000, self.error_register, code.fault_code, code.code, 0)

    def clear_history(self) -> None:
        """0x1003 sub 0 written with 0."""
        self.history.clear()

    def _send(self, code: int, register: int, fault_code: int, detail: int, count: int) -> bool:
        if not self._gate():
            self.suppressed += 1
            return False
        mfr = bytes((fault_code & 0xFF, detail & 0xFF, (detail >> 8) & 0xFF,
                     count & 0xFF, (count >> 8) & 0xFF))
        self.producer.send(code, register, mfr)
        self.sent += 1
        return True
