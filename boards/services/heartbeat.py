"""CiA 301 heartbeat producer (0x1017) and consumer (0x1016) on the simulation clock.

canopen's ``NmtSlave.start_heartbeat`` uses ``network.send_periodic`` — a python-can
``CyclicSendTask`` on the wall clock, a thread on most interfaces — so it cannot run in
simulated time. The producer here is a :class:`boards.peripherals.Timer` (one scheduler event
per period, exact to the microsecond); the consumer arms one scheduler deadline per monitored
node and re-arms it on every heartbeat received.
"""

from __future__ import annotations

from typing import Callable, Dict, Optional

from boards.peripherals import Timer
from bus.eds.objects import heartbeat_cob_id
from bus.scheduler import PRIO_BACKGROUND, Scheduler

__all__ = ["HeartbeatProducer", "HeartbeatConsumer"]


class HeartbeatProducer:
    """Sends the 1-byte NMT state on 0x700 + node every ``period_ms`` (0 = off).

    Parameters
    ----------
    scheduler : Scheduler
    node_id : int
    state : callable
        ``state() -> int``: the NMT state byte (4 STOPPED, 5 OPERATIONAL, 127 PRE-OPERATIONAL).
    send : callable
        ``send(can_id, data)``.
    owner : str
        Name shown in scheduler errors.
    """

    def __init__(self, scheduler: Scheduler, node_id: int, state: Callable[[], int],
                 send: Callable[[int, bytes], None], owner: str = "heartbeat") -> None:
        self.cob_id = heartbeat_cob_id(node_id)
        self._state = state
        self._send = send
        self.period_ms = 0
        self.sent = 0
        self.timer = Timer(scheduler, 1_000, self._beat, priority=PRIO_BACKGROUND, owner=owner)

    def set_period_ms(self, period_ms: int) -> None:
        """Restart with a new period from now (CiA 301: a write of 0x1017 takes effect at once)."""
        self.period_ms = int(period_ms)
        self.timer.stop()
        if self.period_ms > 0:
            self.timer.period_us = self.period_ms * 1000
            self.timer.start()

    def stop(self) -> None:
        """Stop beating (power off, reset)."""
        self.timer.reset()

    def _beat(self, now_us: int) -> None:
        self.sent += 1
        self._send(self.cob_id, bytes((self._state() & 0x7F,)))


class HeartbeatConsumer:
    """Watches the heartbeats of the nodes listed in 0x1016.

    Monitoring of a node starts at its first heartbeat (CiA 301 §7.2.8.3.2.2); if no further
    heartbeat arrives within its time, ``on_event(node_id, True)`` is called once; the next
    heartbeat calls ``on_event(node_id, False)``.

    Parameters
    ----------
    scheduler : Scheduler
    on_event : callable
        ``on_event(node_id: int, lost: bool)``.
    owner : str
        Name shown in scheduler errors.
    """

    def __init__(self, scheduler: Scheduler, on_event: Callable[[int, bool], None],
                 owner: str = "heartbeat-consumer") -> None:
        self.scheduler = scheduler
        self._on_event = on_event
        self.owner = owner
        self.times_ms: Dict[int, int] = {}        # node id -> consumer time, ms (> 0)
        self._deadline: Dict[int, object] = {}
        self.lost: Dict[int, bool] = {}
        self.last_rx_us: Dict[int, Optional[int]] = {}

    def configure(self, times_ms: Dict[int, int]) -> None:
        """Set the monitored nodes (node id -> time ms; time 0 removes the node)."""
        self.stop()
        self.times_ms = {int(n): int(t) for n, t in times_ms.items() if n and t}
        self.lost = {n: False for n in self.times_ms}
        self.last_rx_us = {n: None for n in self.times_ms}

    def stop(self) -> None:
        """Cancel every deadline (reset, power off)."""
        for ev in self._deadline.values():
            self.scheduler.cancel(ev)
        self._deadline.clear()

    def on_heartbeat(self, node_id: int) -> None:
        """A heartbeat (or boot-up) of ``node_id`` arrived now."""
        if node_id not in self.times_ms:
            return
        now = self.scheduler.now_us
        self.last_rx_us[node_id] = now
        ev = self._deadline.pop(node_id, None)
        if ev is not None:
            self.scheduler.cancel(ev)
        self._deadline[node_id] = self.scheduler.call_at(
            now + self.times_ms[node_id] * 1000, lambda t, n=node_id: self._timeout(n),
            PRIO_BACKGROUND, owner=self.owner)
        if self.lost.get(node_id):
            self.lost[node_id] = False
            self._on_event(node_id, False)

    def _timeout(self, node_id: int) -> None:
        self._deadline.pop(node_id, None)
        if not self.lost.get(node_id):
            self.lost[node_id] = True
            self._on_event(node_id, True)
