"""python-can interface ``schmidt-sim``: a BusABC on the emulated CAN network, in simulated time.

``can.Bus(interface="schmidt-sim", channel="telescope")`` attaches to the
:class:`~bus.network.CanNetwork` registered under ``"telescope"`` (create that first, with the
scheduler), or pass ``network=`` explicitly.

Semantics that differ from a hardware bus, because time is simulated:

* ``send`` queues the frame for arbitration and returns at once; it never blocks or times out.
* ``recv(timeout)`` and ``_recv_internal(timeout)`` return the next delivered frame or ``None``
  immediately, whatever the timeout: nothing can arrive while the caller blocks, because the
  scheduler is not running. (BusABC's ``recv(None)`` would spin forever; it is overridden.)
* ``can_filters`` act as the controller's acceptance filters: a frame that does not match is
  dropped at delivery and raises no receive interrupt.
* Each receiver gets its own ``can.Message``, built when the program reads the frame
  (``recv``, ``drain_rx``): the network queues a :class:`~bus.network.RxFrame` (end time,
  identifier, data) in every accepting bus and builds no Message for the emulated boards, whose
  CAN controllers read the RxFrame itself (``drain_rx_frames``; docs/performance.md, session 8).
* ``set_rx_callback(fn)``: ``fn()`` is called at the frame's end time, once every receiver holds
  the frame (inside the network's ``PRIO_CAN`` completion event), after each accepted
  delivery — the receive interrupt. Plain python-can buses have no such hook; boards poll.
* No Notifier threads or ``send_periodic`` inside simulated time (BusABC's thread-based
  periodic tasks would use the wall clock); schedule periodic sends on the scheduler.
"""

from __future__ import annotations

from collections import deque
from typing import Callable

import can

from bus._native import own_abc_cache
from bus.errors import BusError
from bus.network import CanNetwork, NodeErrorState, RxFrame, get_network

__all__ = ["SimBus"]


class SimBus(can.BusABC):
    """One node's CAN controller on a simulated :class:`~bus.network.CanNetwork`.

    Parameters
    ----------
    channel : str
        Network name in the registry (default ``"telescope"``).
    can_filters : list of dict, optional
        python-can filters, applied at delivery (acceptance filtering).
    network : CanNetwork, optional
        Attach to this network instead of looking ``channel`` up.
    receive_own_messages : bool
        Also deliver this bus's own frames back to it (``is_rx=False``), default False.
    name : str, optional
        Owner name used in scheduler errors for the rx callback (e.g. ``"ra-axis"``).
    rx_queue_size : int, optional
        Maximum frames kept for ``recv``; older frames are dropped first and counted in
        ``rx_overruns`` (a controller's receive buffer overflow). Default: unbounded.
    """

    def __init__(self, channel: str = "telescope", can_filters=None, *,
                 network: CanNetwork | None = None, receive_own_messages: bool = False,
                 name: str | None = None, rx_queue_size: int | None = None, **kwargs) -> None:
        if channel is None:
            channel = network.channel if network is not None else "telescope"
        self.network = network if network is not None else get_network(channel)
        self.channel = self.network.channel
        self.channel_info = f"schmidt-sim channel {self.channel!r}"
        self.receive_own_messages = receive_own_messages
        self.name = name or f"simbus:{self.channel}"
        self._scheduler = self.network.scheduler
        self._rx: deque = deque()
        self._rx_queue_size = rx_queue_size
        self.rx_overruns = 0
        self._rx_callback: Callable[[], object] | None = None
        self._exact_ids: frozenset | None = None
        self._attached = False
        super().__init__(channel=self.channel, can_filters=can_filters, **kwargs)
        self.network.attach(self)
        self._attached = True

    # -- transmit ---------------------------------------------------------------------------
    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        """Queue ``msg`` for arbitration (never blocks; ``timeout`` is ignored).

        Raises
        ------
        can.CanOperationError
            While this node is bus-off (fault confinement, :mod:`bus.network`).
        bus.errors.BusError
            After shutdown, or for frames the network does not emulate (extended, remote, FD,
            more than 8 bytes).
        """
        if not self._attached:
            raise BusError(f"{self.name}: send on a shut-down bus")
        self.network.submit(self, msg)

    def send_frame(self, arbitration_id: int, data: bytes) -> None:
        """Queue a standard data frame given as identifier and data (no ``can.Message`` built).

        The same as ``send(can.Message(arbitration_id=..., data=..., is_extended_id=False))``,
        for the boards' CAN controllers (the hot path); same errors as :meth:`send`.
        """
        if not self._attached:
            raise BusError(f"{self.name}: send on a shut-down bus")
        self.network.submit_frame(self, arbitration_id, bytes(data))

    def set_tx_buffers(self, n: int, tx_priority) -> None:
        """Transmit through ``n`` hardware buffers chosen by priority (``tx_priority(id)`` ->
        TXP 0..3; ties: the highest buffer number) with a FIFO in front, as an MCP2515 or PIC18
        ECAN controller (``bus.network.TxBuffers``), instead of one FIFO. Only while nothing
        is queued; raises ``BusError`` otherwise."""
        self.network.set_tx_buffers(self, n, tx_priority)

    # -- receive ----------------------------------------------------------------------------
    def _apply_filters(self, filters) -> None:
        """python-can hook: precompute a set when every filter is an exact 11-bit match."""
        self._exact_ids = None
        if filters and all(f.get("can_mask") == 0x7FF and not f.get("extended", False) for f in filters):
            self._exact_ids = frozenset(f["can_id"] for f in filters)
        network = getattr(self, "network", None)
        if network is not None:
            network.filters_changed()

    def _accepts(self, arbitration_id: int) -> bool:
        """True if the acceptance filters pass a standard frame with this identifier (the
        network asks once per identifier and keeps the answer until the filters change)."""
        exact = self._exact_ids
        if exact is not None:
            return arbitration_id in exact
        if self._filters is None:
            return True
        return self._matches_filters(can.Message(arbitration_id=arbitration_id, is_extended_id=False))

    def _deliver(self, msg: can.Message) -> bool:
        """Deliver ``msg`` through the acceptance filters (the network's entry for attached
        objects without ``_accepts``; it reaches a SimBus through ``_enqueue_frame`` instead).
        ``msg`` may be shared with other receivers: read-only.

        Returns True when the frame was queued and a receive interrupt is installed: the network
        then calls :meth:`_fire` once every receiver has the frame, at the frame's end time.
        """
        exact = self._exact_ids
        if exact is not None:
            if msg.arbitration_id not in exact or msg.is_extended_id:
                return False
        elif self._filters is not None and not self._matches_filters(msg):
            return False
        return self._enqueue(msg)

    def _enqueue(self, msg: can.Message | RxFrame) -> bool:
        """Queue a frame the filters accept (see :meth:`_deliver`); the network's delivery table
        calls this directly for the identifiers :meth:`_accepts` passes."""
        rx = self._rx
        if self._rx_queue_size is not None and len(rx) >= self._rx_queue_size:
            rx.popleft()
            self.rx_overruns += 1
        rx.append(msg)
        return self._rx_callback is not None

    def _enqueue_frame(self, frame: RxFrame) -> bool:
        """:meth:`_enqueue` for a received frame as the network has it (no ``can.Message``
        built: :meth:`recv` and :meth:`drain_rx` build it when a program reads the frame)."""
        return self._enqueue(frame)

    def _message(self, item) -> can.Message:
        """A queued item as the ``can.Message`` python-can promises (own frames already are)."""
        return item.message(self.channel) if item.__class__ is RxFrame else item

    def _fire(self, now_us: int) -> None:
        cb = self._rx_callback
        if cb is not None:
            cb()

    def _recv_internal(self, timeout: float | None):
        """Return ``(next delivered frame, True)`` or ``(None, False)`` at once."""
        if self._rx:
            return self._message(self._rx.popleft()), True
        return None, False

    def recv(self, timeout: float | None = None) -> can.Message | None:
        """Next delivered frame or ``None`` at once (``timeout`` is ignored: simulated time)."""
        if self._rx:
            return self._message(self._rx.popleft())
        return None

    def drain_rx(self) -> list:
        """Every frame delivered and not yet read, oldest first, removed from the queue (what
        ``recv()`` would return one by one until ``None``): a list of ``can.Message``."""
        rx = self._rx
        if not rx:
            return []
        out = [self._message(m) for m in rx]
        rx.clear()
        return out

    def drain_rx_frames(self) -> list[RxFrame]:
        """:meth:`drain_rx` as :class:`~bus.network.RxFrame` objects, without building a
        ``can.Message`` (the emulated boards' CAN controllers; the hot path). A frame of this
        node's own (``receive_own_messages``) is given with the time it was received at."""
        rx = self._rx
        if not rx:
            return []
        out: list[RxFrame] = []
        for m in rx:
            if m.__class__ is RxFrame:
                out.append(m)
            else:
                out.append(RxFrame(round(m.timestamp * 1e6), m.arbitration_id, bytes(m.data)))
        rx.clear()
        return out

    def set_rx_callback(self, fn: Callable[[], object] | None) -> None:
        """Install the receive interrupt: ``fn()`` runs at the end of each accepted delivery.
        (The network's receivers table holds the callback, so it is told to rebuild.)"""
        self._rx_callback = fn
        if self._attached:
            self.network.filters_changed()

    @property
    def rx_pending(self) -> int:
        """Frames delivered and not yet read."""
        return len(self._rx)

    def flush_rx(self) -> None:
        """Drop every frame waiting to be read."""
        self._rx.clear()

    # -- fault confinement ------------------------------------------------------------------
    @property
    def error_state(self) -> "NodeErrorState":
        """This node's :class:`~bus.network.NodeErrorState` (TEC, REC, state, counters)."""
        return self.network.error_state(self)

    def request_recovery(self) -> None:
        """Ask the controller to leave bus-off (takes 128 × 11 recessive bits)."""
        self.network.request_recovery(self)

    # -- lifecycle --------------------------------------------------------------------------
    def shutdown(self) -> None:
        """Detach from the network (idempotent); pending TX frames are dropped."""
        if self._attached:
            self.network.detach(self)
            self._attached = False
        super().shutdown()

    @staticmethod
    def _detect_available_configs():
        from bus.network import _REGISTRY

        return [{"interface": "schmidt-sim", "channel": ch} for ch in _REGISTRY]


own_abc_cache(SimBus)   # compiled by mypyc: see bus._native.own_abc_cache
