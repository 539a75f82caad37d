"""A canopen ``Network`` with no bus, no Notifier thread and no periodic tasks.

canopen documents two seams for a custom backend (``canopen/network.py``):
:meth:`canopen.Network.notify` feeds a received frame to the subscribed services, and
:meth:`canopen.Network.send_message` "may be overridden in a subclass if you need to integrate
this library with a custom backend". :class:`SimNetwork` uses exactly those two: the board's
receive interrupt calls ``notify`` and ``send_message`` hands the frame to the board's CAN
controller. ``connect`` (which would start a python-can ``Notifier`` thread) and
``send_periodic`` (a wall-clock ``CyclicSendTask``) are refused: in simulated time periodic
frames are sent from scheduler timers (:mod:`boards.services.heartbeat`).
"""

from __future__ import annotations

from typing import Callable

import canopen

__all__ = ["SimNetwork"]


class SimNetwork(canopen.Network):
    """canopen network of one board, driven from simulated time.

    Parameters
    ----------
    transmit : callable
        ``transmit(can_id: int, data: bytes)``: queue a standard data frame on the board's CAN
        controller (never blocks).
    """

    def __init__(self, transmit: Callable[[int, bytes], None]) -> None:
        super().__init__(bus=None)
        self._transmit = transmit

    def connect(self, *args, **kwargs):
        """Refused: it would start a python-can Notifier thread (frames come via :meth:`notify`)."""
        raise RuntimeError("SimNetwork has no bus of its own: feed frames with notify()")

    def send_message(self, can_id: int, data: bytes, remote: bool = False) -> None:
        """Transmit through the board's CAN controller (remote frames are not used by CiA 301 here)."""
        if remote:
            raise ValueError(f"remote frame on 0x{can_id:03X}: not supported in simulated time")
        self._transmit(int(can_id), bytes(data))

    def send_periodic(self, can_id, data, period, remote=False):
        """Refused: python-can periodic tasks run on the wall clock; use a scheduler timer."""
        raise RuntimeError(f"send_periodic(0x{can_id:03X}) needs the wall clock; in simulated time "
                           "periodic frames come from scheduler timers")
