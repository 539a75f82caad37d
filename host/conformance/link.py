"""The conformance host's bus: any python-can bus, in simulated or in real time.

:class:`Link` owns one python-can bus and one clock. Every frame it receives is kept in
:attr:`Link.frames` and handed to its canopen master network (``RemoteNode``s: SDO client, EMCY
consumer). Checks wait with :meth:`Link.wait` / :meth:`Link.pump_until`:

* in simulated time (the in-process emulator), waiting advances the emulator's clock
  (``advance(dt_us)``) in ``step_s`` steps and drains the bus (nothing arrives while ``recv``
  waits on that bus: it returns at once); timestamps are simulated seconds;
* in real time (``serve`` on vcan0, real boards on can0) waiting is ``bus.recv(timeout)``;
  timestamps are the kernel's (``time.time()`` base).

The conformance host produces its own CiA heartbeat (node 0x10, docs/protocol.md) every
second while it waits, unless :attr:`Link.heartbeat_on` is False.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable, List, Optional

import can
import canopen

__all__ = ["Frame", "Link", "MasterNetwork", "HOST_NODE"]

#: The host's node id (docs/protocol.md: 0x10, device type 0x10 HOST).
HOST_NODE = 0x10


@dataclass(frozen=True)
class Frame:
    """A received frame: time (s, the link's clock), identifier, payload."""

    t: float
    cob_id: int
    data: bytes


class MasterNetwork(canopen.Network):
    """canopen master on a :class:`Link`: a sent SDO request waits (pumps the link) for its answer.

    canopen's SDO client blocks on a queue after each request; here ``send_message`` pumps the
    link until the answer (0x580 + node) is in, or ``sdo_timeout_s``, so the client finds it
    queued: no Notifier thread, no periodic task.
    """

    def __init__(self, link: "Link", sdo_timeout_s: float):
        super().__init__(bus=None)
        self.link = link
        self.sdo_timeout_s = sdo_timeout_s

    def send_message(self, can_id, data, remote=False):
        self.link.send(can_id, bytes(data))
        if 0x600 <= can_id < 0x680:
            want = can_id - 0x80
            self.link.pump_until(lambda f: f.cob_id == want, self.sdo_timeout_s)

    def send_periodic(self, *a, **k):
        raise RuntimeError("the conformance host sends no wall-clock periodic tasks")

    def add_remote(self, node_id: int, od) -> canopen.RemoteNode:
        node = canopen.RemoteNode(node_id, od)
        node.sdo.RESPONSE_TIMEOUT = 0.01     # the answer is already queued (or never comes)
        node.sdo.MAX_RETRIES = 1         # one attempt (canopen counts the first try; 0 loops for ever)
        self.add_node(node)
        return node


class Link:
    """One python-can bus and its clock (see the module docstring).

    Parameters
    ----------
    bus : can.BusABC
    advance : callable or None
        ``advance(until_s)``: run the emulator's clock to ``until_s`` (simulated time); None on a
        real bus (real time).
    now : callable
        The clock, seconds (simulated, or ``time.time``).
    step_s : float
        Simulated-time step while waiting, s (100 µs).
    sdo_timeout_s : float
        How long an SDO request waits for its answer, s.
    """

    def __init__(self, bus: can.BusABC, advance: Optional[Callable[[float], None]],
                 now: Callable[[], float], *, step_s: float = 100e-6, sdo_timeout_s: float = 0.1,
                 description: str = "", close: Optional[Callable[[], None]] = None):
        self.bus = bus
        self._advance = advance
        self.now = now
        self.step_s = step_s
        self.simulated = advance is not None
        self.description = description
        self.frames: List[Frame] = []
        self.sent: List[Frame] = []
        self.master = MasterNetwork(self, sdo_timeout_s)
        self.heartbeat_on = True
        self.heartbeat_state = 0x05
        self._next_beat = self.now()
        self._close = close

    # -------------------------------------------------------------------------- sending
    def send(self, cob_id: int, data: bytes) -> None:
        """Send one standard (11-bit) data frame."""
        self.sent.append(Frame(self.now(), cob_id, bytes(data)))
        self.bus.send(can.Message(arbitration_id=cob_id, data=bytes(data), is_extended_id=False))

    def _beat(self) -> None:
        if self.heartbeat_on and self.now() >= self._next_beat:
            self._next_beat = self.now() + 1.0
            self.send(0x700 + HOST_NODE, bytes((self.heartbeat_state,)))

    # -------------------------------------------------------------------------- receiving
    def _take(self, msg: can.Message) -> Frame:
        f = Frame(float(msg.timestamp) if not self.simulated or msg.timestamp else self.now(),
                  msg.arbitration_id, bytes(msg.data))
        self.frames.append(f)
        if not msg.is_error_frame and not msg.is_remote_frame:
            self.master.notify(f.cob_id, bytearray(f.data), f.t)
        return f

    def _poll(self, until_s: float) -> List[Frame]:
        """Advance to ``until_s`` at most one step; return the frames received meanwhile."""
        got: List[Frame] = []
        if self.simulated:
            self._advance(min(until_s, self.now() + self.step_s))
            while (m := self.bus.recv(0.0)) is not None:
                got.append(self._take(m))
        else:
            timeout = max(0.0, min(until_s - self.now(), 0.05))
            m = self.bus.recv(timeout)
            while m is not None:
                got.append(self._take(m))
                m = self.bus.recv(0.0)
        self._beat()
        return got

    def wait(self, dt_s: float) -> List[Frame]:
        """Let ``dt_s`` pass; return every frame received meanwhile."""
        end = self.now() + dt_s
        out: List[Frame] = []
        while self.now() < end:
            out.extend(self._poll(end))
        return out

    def pump_until(self, pred: Callable[[Frame], bool], timeout_s: float) -> Optional[Frame]:
        """Wait until a received frame satisfies ``pred`` (returned) or ``timeout_s`` (None)."""
        end = self.now() + timeout_s
        while self.now() < end:
            for f in self._poll(end):
                if pred(f):
                    return f
        return None

    def close(self) -> None:
        try:
            self.bus.shutdown()
        finally:
            if self._close is not None:
                self._close()


def open_real_link(interface: str, channel: str, bitrate: Optional[int] = None,
                   sdo_timeout_s: float = 0.1) -> Link:
    """A link on a python-can bus in real time (socketcan vcan0/can0, or any interface).

    Raises
    ------
    ValueError
        The bus cannot be opened (one line naming interface and channel).
    """
    kwargs = {"interface": interface, "channel": channel, "receive_own_messages": False}
    if bitrate:
        kwargs["bitrate"] = bitrate
    try:
        bus = can.Bus(**kwargs)
    except (OSError, can.CanError, ValueError, ImportError) as exc:
        raise ValueError(f"cannot open {interface} channel {channel!r} ({exc})") from None
    return Link(bus, None, time.time, sdo_timeout_s=sdo_timeout_s,
                description=f"{interface} {channel} (real time)")
