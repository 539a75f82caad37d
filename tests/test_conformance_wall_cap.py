"""A conformance host descheduled past a window's wall cap still reads what came in the window.

CI's QEMU guest stops the host process for seconds at a time (docs/conformance.md, "The host's
own heartbeat": beats 4–9 s of wall apart). A window on the devices' clock is capped at
``dt / min_rate + 1`` wall seconds so that devices that stand still cannot hang the suite; a host
that woke up past that cap gave up without reading its receive queue, and lost an SDO answer the
devices had sent 2 ms after the request (guest run of session 38: ``test_sdo_latency``, "No SDO
response received"). Here the devices are a small independent model (one 10 ms PDO stream, an SDO
server answering after a set delay, both on their own time base, which runs with the wall clock)
and the host is stopped right after its request, as the guest's scheduler does.
"""

from __future__ import annotations

from collections import deque

import can

from host.conformance.link import DeviceClock, Link

PDO = 0x181          # a 10 ms stream (the reader's POSITION period, docs/conformance.md)
PERIOD_S = 0.010
REQUEST, ANSWER = 0x601, 0x581


class Devices:
    """A python-can-like bus whose far side runs on the wall clock ``wall[0]``.

    ``recv(timeout)`` returns the next queued frame, or lets ``timeout`` of wall time pass (the
    devices run on meanwhile). ``send`` of an SDO request queues the answer ``answer_after_s``
    later on the devices' time and, with ``stall_s``, stops the host the next time it finds its
    receive queue empty (the wall clock jumps while the devices keep sending): the moment between
    two polls where nothing is read, which a scheduler may pick as well as any other."""

    def __init__(self, wall, answer_after_s: float, stall_s: float):
        self.wall = wall
        self.answer_after_s = answer_after_s
        self.stall_s = stall_s
        self.next_pdo = 0.0
        self.pending: list = []         # (device time, message) of answers not yet on the bus
        self.q: deque = deque()
        self.stall_next = False

    def _run_to(self, t: float) -> None:
        while True:
            t_ans = self.pending[0][0] if self.pending else float("inf")
            t_nxt = min(self.next_pdo, t_ans)
            if t_nxt > t:
                return
            if t_ans <= self.next_pdo:
                self.q.append(self.pending.pop(0)[1])
            else:
                self.q.append(can.Message(arbitration_id=PDO, data=bytes(8), is_extended_id=False,
                                          timestamp=self.next_pdo))
                self.next_pdo += PERIOD_S

    def recv(self, timeout=None):
        self._run_to(self.wall[0])
        if not self.q and timeout:
            self.wall[0] += timeout
            self._run_to(self.wall[0])
        if self.q:
            return self.q.popleft()
        if self.stall_next:        # the host found its queue empty and is then not scheduled
            self.stall_next = False
            self.wall[0] += self.stall_s
        return None

    def send(self, msg, timeout=None):
        if msg.arbitration_id == REQUEST:
            t = self.wall[0] + self.answer_after_s
            self.pending.append((t, can.Message(arbitration_id=ANSWER, data=bytes(8), is_extended_id=False,
                                                timestamp=t)))
            self.stall_next = self.stall_s > 0   # ... from its first poll for the answer

    def shutdown(self):
        pass


def _link(answer_after_s: float, stall_s: float) -> tuple[Link, Devices]:
    wall = [0.0]
    dev = Devices(wall, answer_after_s, stall_s)
    link = Link(dev, None, lambda: wall[0], sdo_timeout_s=0.1, min_rate=0.05,
                device_clock=DeviceClock({PDO: PERIOD_S}, None))
    link.wait(0.2)          # the stream is heard: the devices' clock runs
    link.heartbeat_on = False
    return link, dev


def _request(link: Link):
    link.send(REQUEST, bytes(8))
    return link.pump_until(lambda f: f.cob_id == ANSWER, link.master.sdo_timeout_s)


def test_answer_in_time_is_found_after_the_host_slept_past_the_wall_cap():
    """Answer 50 ms after the request, host stopped 10 s after its first poll (> the 3.3 s cap of
    a 0.1 s window): the answer is found, stamped inside the window on the devices' clock; the
    wait is not counted as capped (the devices' clock moved on)."""
    link, dev = _link(answer_after_s=0.05, stall_s=10.0)
    t0 = link.now()
    got = link.pump_until(lambda f: False, 0.0)          # nothing: a zero window
    assert got is None
    f = _request(link)
    assert f is not None and f.cob_id == ANSWER
    assert t0 <= f.t <= t0 + 0.1 + link.clock.resolution_s() + 0.02
    assert link.capped_waits == 0
    assert link.clock.now > t0 + 9.0        # the backlog was counted


def test_late_answer_is_still_late_after_the_host_slept():
    """Answer 0.5 s after the request (outside the 0.1 s window), host stopped 10 s: not taken for
    an answer in time, though it sits in the same backlog."""
    link, _ = _link(answer_after_s=0.5, stall_s=10.0)
    assert _request(link) is None
    assert any(f.cob_id == ANSWER for f in link.frames)   # it was read, and judged late
    assert link.capped_waits == 0


def test_devices_that_stand_still_still_end_the_wait_on_the_cap():
    """Devices that send nothing after the request (the cap's purpose): the wait ends on the wall
    cap, counted as capped, with no answer."""
    wall = [0.0]
    dev = Devices(wall, answer_after_s=1e9, stall_s=0.0)
    link = Link(dev, None, lambda: wall[0], sdo_timeout_s=0.1, min_rate=0.05,
                device_clock=DeviceClock({PDO: PERIOD_S}, None))
    link.wait(0.2)
    link.heartbeat_on = False
    dev.next_pdo = float("inf")              # the stream stops
    w0 = wall[0]
    assert _request(link) is None
    assert link.capped_waits == 1
    assert wall[0] - w0 >= 0.1 / 0.05        # waited the cap, not less


def test_without_the_stall_the_answer_is_found_as_before():
    link, _ = _link(answer_after_s=0.002, stall_s=0.0)
    f = _request(link)
    assert f is not None and link.capped_waits == 0
