"""The conformance host's bus: any python-can bus, in simulated or in real time.

:class:`Link` owns one python-can bus and one clock. Every frame it receives is kept in
:attr:`Link.frames` and handed to its canopen master network (``RemoteNode``s: SDO client, EMCY
consumer). Checks wait with :meth:`Link.wait` / :meth:`Link.pump_until`:

* in simulated time (the in-process emulator), waiting advances the emulator's clock
  (``advance(dt_us)``) in ``step_s`` steps and drains the bus (nothing arrives while ``recv``
  waits on that bus: it returns at once); timestamps are simulated seconds;
* in real time (``serve`` on vcan0, real boards on can0) waiting is ``bus.recv(timeout)``;
  the kernel's timestamps (``time.time()`` base) are kept as each frame's ``wall``.

On a real bus the link's time (:meth:`Link.now`, each frame's ``t``) is by default the
**devices' own clock** (:class:`DeviceClock`): counted from the periodic frames the nodes send
at their documented periods (DBC ``GenMsgCycleTime`` = EDS event timer; the CiA heartbeat at
0x1017), so a wait of 50 ms is 50 ms of the boards' time however fast the boards (or an
emulator behind ``serve``) run against the wall clock. Every wait also has a wall-clock cap
(``dt / min_rate``) so a silent bus cannot hang the suite. The timing checks use ``wall``
(docs/conformance.md, "Which clock").

The conformance host produces its own CiA heartbeat (node 0x10, docs/protocol.md) every
second, unless :attr:`Link.heartbeat_on` is False: whenever one second has passed on the link's
clock *or* on the wall clock since the last beat, checked at every frame it takes, every poll,
:meth:`Link.now` and :meth:`Link.send`. The devices' clock keeps the beats one device second
apart while the host reads as fast as frames arrive, even when an emulator catches up after a
stall faster than real time; the wall clock keeps them while the host falls behind reading (its
count of the devices' clock then lags) and the devices run at most at real time. A host process
descheduled for seconds beats late on both; the suite re-runs a test the devices then failed
for it (``plugin.pytest_pyfunc_call``; docs/conformance.md, "The host's own heartbeat").
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable, Dict, List, Optional

import can
import canopen

__all__ = ["DeviceClock", "Frame", "Link", "MasterNetwork", "HOST_NODE"]

#: The host's node id (docs/protocol.md: 0x10, device type 0x10 HOST).
HOST_NODE = 0x10


@dataclass(frozen=True)
class Frame:
    """A received frame: time (s, the link's clock: simulated or the devices'), identifier,
    payload, and the receiver's wall-clock time (s; simulated time in-process)."""

    t: float
    cob_id: int
    data: bytes
    wall: float = 0.0


class DeviceClock:
    """Time on the devices' clock, counted from the periodic frames they send.

    Each periodic stream (a COB-ID with a documented period ``p``) is a clock: its frames are
    ``p`` apart on the sending device's time base, each sent at most ``jitter`` after its
    scheduled time (queueing behind other frames). A frame of a stream that is not behind the
    clock is stamped ``previous stamp + p``; the clock's value is the largest stamp so far. A
    stream's first frame, its first after a pause, and any frame that falls behind the clock is
    stamped with the clock's value and the stream is re-anchored ``jitter`` earlier (that frame
    may have been queued), so a stream's stamps never run ahead of its schedule and queueing
    delays cannot ratchet the clock forward. Every stamp is therefore a lower bound of the
    device time at which its frame was on the bus; the clock lags that time by at most one
    period of the fastest stream heard plus twice its jitter (10 ms + 4 ms while any axis or
    reader is OPERATIONAL; 1 s + 20 ms when only heartbeats are heard): :meth:`resolution_s`,
    which the link adds to every window. A heartbeat with state 0x00 (boot-up) is not periodic: it ends
    the node's heartbeat stream.

    Parameters
    ----------
    periods_s : dict
        ``{COB-ID: period s}`` of the cyclic PDOs (DBC GenMsgCycleTime).
    heartbeat_period_s : float or None
        The documented producer heartbeat time (EDS 0x1017), s; None: heartbeats are not used.
    pdo_jitter_s, heartbeat_jitter_s : float
        Largest queueing delay of a PDO / a heartbeat, s (the suite's documented tolerances,
        docs/conformance.md: 2 ms and 10 ms).

    Attributes
    ----------
    now : float
        Device time, s, from 0 at the link's opening.
    frames_counted : int
        Frames that advanced a stream.
    """

    def __init__(self, periods_s: Dict[int, float], heartbeat_period_s: Optional[float],
                 pdo_jitter_s: float = 0.002, heartbeat_jitter_s: float = 0.010):
        self.periods_s = dict(periods_s)
        self.heartbeat_period_s = heartbeat_period_s
        self.pdo_jitter_s = float(pdo_jitter_s)
        self.heartbeat_jitter_s = float(heartbeat_jitter_s)
        self.now = 0.0
        self.frames_counted = 0
        self._last: Dict[int, float] = {}       # stream -> its schedule: stamp of its last frame
        self._period: Dict[int, tuple] = {}     # stream -> (period, jitter)

    def resolution_s(self) -> float:
        """How far ``now`` may lag the devices' time, s: period + twice the jitter of the fastest
        stream heard within its last two periods (its stamps run up to one jitter behind its
        schedule, and its last frame may have been queued for one more; 0 when no stream is
        heard: nothing advances the clock).

        A window measured from ``now`` is lengthened by this much, because ``now`` may lag the
        device's time at its start by that much: a stamp is a lower bound of a *time*, not of an
        *interval*."""
        best = 0.0
        for cob, last in self._last.items():
            p, j = self._period[cob]
            if self.now - last <= 2 * p + j and (best == 0.0 or p + 2 * j < best):
                best = p + 2 * j
        return best

    def on_frame(self, cob_id: int, data: bytes) -> float:
        """Account for a received frame; return the clock's value after it."""
        if 0x701 <= cob_id <= 0x77F and len(data) == 1 and self.heartbeat_period_s:
            if data[0] == 0x00:                        # boot-up: the node starts a new stream
                self._last.pop(cob_id, None)
                return self.now
            period, jitter = self.heartbeat_period_s, self.heartbeat_jitter_s
        else:
            period = self.periods_s.get(cob_id)
            if period is None:
                return self.now
            jitter = self.pdo_jitter_s
        last = self._last.get(cob_id)
        if last is None or last + period < self.now:     # new, paused or behind: re-anchor
            self._last[cob_id] = self.now - jitter
            stamp = self.now
        else:
            stamp = last + period
            self._last[cob_id] = stamp
        self._period[cob_id] = (period, jitter)
        self.now = max(self.now, stamp)
        self.frames_counted += 1
        return stamp


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
        The receiver's clock, seconds (simulated, ``time.time``, or a test's virtual wall clock).
    step_s : float
        Step of ``now`` while waiting, s (100 µs of simulated time).
    sdo_timeout_s : float
        How long an SDO request waits for its answer, s (the link's time).
    device_clock : DeviceClock or None
        Measure the link's time on the devices' clock (see the module docstring); None: the
        link's time is ``now``.
    min_rate : float
        With a device clock: a wait of ``dt`` gives up after ``dt / min_rate`` of ``now`` (the
        slowest device rate, device s per wall s, the suite waits for).
    """

    def __init__(self, bus: can.BusABC, advance: Optional[Callable[[float], None]],
                 now: Callable[[], float], *, step_s: float = 100e-6, sdo_timeout_s: float = 0.1,
                 description: str = "", close: Optional[Callable[[], None]] = None,
                 device_clock: Optional[DeviceClock] = None, min_rate: float = 0.05):
        self.bus = bus
        self._advance = advance
        self.wall = now
        self.step_s = step_s
        self.simulated = advance is not None
        self.clock = device_clock
        self.min_rate = float(min_rate)
        self.capped_waits = 0
        #: what ``now`` is: "simulated", "wall" or (a test's) "virtual wall"
        self.wall_kind = "simulated" if self.simulated else "wall"
        self.description = description
        self.frames: List[Frame] = []
        self._by_cob: Dict[int, List[Frame]] = {}
        self.sent: List[Frame] = []
        self._sent_after: Dict[int, int] = {}    # id(frame of ``sent``) -> len(frames) at its send
        self.master = MasterNetwork(self, sdo_timeout_s)
        self._heartbeat_on = True
        #: how many times :attr:`heartbeat_on` went False (a check silencing the host on purpose)
        self.silences = 0
        self.heartbeat_state = 0x05
        #: test aid (``open_emulator_link(rate=...)``): called by :meth:`now` before it reads; it may
        #: let the devices run on while the host computes (frames wait in its receive queue)
        self.host_busy: Optional[Callable[[], None]] = None
        self._wall0 = self.wall()
        self._next_beat = self._now()
        self._next_beat_wall = self._wall0
        self._close = close

    @property
    def heartbeat_on(self) -> bool:
        """Whether the host sends its heartbeat (0x710); a check sets it False to go silent."""
        return self._heartbeat_on

    @heartbeat_on.setter
    def heartbeat_on(self, on: bool) -> None:
        if self._heartbeat_on and not on:
            self.silences += 1
        self._heartbeat_on = bool(on)

    def now(self) -> float:
        """The link's time, s: the devices' clock (with a :class:`DeviceClock`) or ``wall()``,
        after taking every frame already waiting in the receive queue.

        A window is measured from this value (``t = link.now(); link.send(...);
        link.wait(dt)``). On the devices' clock, frames still unread when the host stamps its
        send would advance the clock during the wait although they were on the bus before the
        send: a host that fell behind reading (a stalled process) would end its windows early.
        Draining first makes the stamp as fresh as the frames received (docs/conformance.md,
        "Which clock")."""
        if self.host_busy is not None:
            self.host_busy()
        self._drain()
        self._beat()
        return self._now()

    def _now(self) -> float:
        return self.clock.now if self.clock is not None else self.wall()

    def _drain(self) -> List[Frame]:
        """Take every frame already received (no waiting, no advance of simulated time); return them."""
        got: List[Frame] = []
        while (m := self.bus.recv(0.0)) is not None:
            got.append(self._take(m))
            self._beat()
        return got

    def frames_of(self, cob_id: int) -> List[Frame]:
        """The frames received on ``cob_id`` so far, in order (the list itself: do not modify).

        The checks look frames up by identifier; scanning :attr:`frames` (every frame received,
        ~10⁵ in a full run) for each lookup kept a slow host from reading its socket while the
        devices ran on (docs/conformance.md, "Which clock")."""
        return self._by_cob.get(cob_id, [])

    def clock_summary(self) -> dict:
        """Which clock the link's time is, and how far it and the wall clock advanced."""
        wall_s = self.wall() - self._wall0
        if self.clock is None:
            return {"clock": self.wall_kind, "elapsed_s": round(wall_s, 3)}
        return {"clock": "device", "device_s": round(self.clock.now, 3), "wall_s": round(wall_s, 3),
                "wall": self.wall_kind,
                "device_s_per_wall_s": round(self.clock.now / wall_s, 4) if wall_s > 0 else None,
                "frames_counted": self.clock.frames_counted, "waits_capped": self.capped_waits,
                "min_rate": self.min_rate}

    # -------------------------------------------------------------------------- sending
    def send(self, cob_id: int, data: bytes) -> None:
        """Send one standard (11-bit) data frame."""
        self._drain()                    # stamped as fresh as the frames received (see now())
        self._beat()
        self._transmit(cob_id, data)

    def _transmit(self, cob_id: int, data: bytes) -> None:
        self.sent.append(Frame(self._now(), cob_id, bytes(data), self.wall()))
        self._sent_after[id(self.sent[-1])] = len(self.frames)
        self.bus.send(can.Message(arbitration_id=cob_id, data=bytes(data), is_extended_id=False))

    def arrival_s(self, sent: Frame) -> float:
        """The link's time at which a frame this host sent reached the devices, s.

        A frame's own stamp ``sent.t`` is the link's time when it went out. The heartbeat
        (``_beat``) also goes out while the host is still taking a backlog of received frames;
        its stamp is then the backlog's time, older than the devices' clock by as much as the
        host lags, and a window measured from it would hold the host's lag against a device.
        So the arrival is the link's time once it took the first frame received *after* the
        send (its receiver wall time, the kernel's receive stamp on SocketCAN, later than the
        send's), which the devices sent after the frame reached them; ``sent.t`` if none came yet.
        Within the clock's resolution (:meth:`DeviceClock.resolution_s`, which every window
        adds), an upper bound of the devices' time at the frame's arrival.

        Parameters
        ----------
        sent : Frame
            An element of :attr:`sent`.

        Raises
        ------
        ValueError
            ``sent`` was not sent on this link.
        """
        # ``sent`` keeps its frames alive, so no other live object shares one of their ids
        first = self._sent_after.get(id(sent))
        if first is None:
            raise ValueError("arrival_s: the frame was not sent on this link")
        t = sent.t
        for f in self.frames[first:]:
            t = max(t, f.t)              # the clock's value after this frame (a stream's own
            if f.wall > sent.wall:       # stamp may lag it by more than the resolution)
                return t
        return sent.t

    def _beat(self) -> None:
        """Send the host heartbeat if one second has passed on the link's clock or on the wall
        clock since the last one (module docstring)."""
        if not self._heartbeat_on:
            return
        wall = self.wall()
        if self._now() >= self._next_beat or wall >= self._next_beat_wall:
            self._next_beat = self._now() + 1.0
            self._next_beat_wall = wall + 1.0
            # not send(): its drain would take frames that the poll calling this does not return
            self._transmit(0x700 + HOST_NODE, bytes((self.heartbeat_state,)))

    # -------------------------------------------------------------------------- receiving
    def _take(self, msg: can.Message) -> Frame:
        wall = float(msg.timestamp) if not self.simulated or msg.timestamp else self.wall()
        if self.clock is not None:
            if self.simulated:              # a test's virtual wall clock: stamp on arrival
                wall = self.wall()
            t = self.clock.on_frame(msg.arbitration_id, bytes(msg.data)) if not (
                msg.is_error_frame or msg.is_remote_frame) else self.clock.now
        else:
            t = wall
        f = Frame(t, msg.arbitration_id, bytes(msg.data), wall)
        self.frames.append(f)
        self._by_cob.setdefault(f.cob_id, []).append(f)
        if not msg.is_error_frame and not msg.is_remote_frame:
            self.master.notify(f.cob_id, bytearray(f.data), f.t)
        return f

    def _poll(self, until_s: float) -> List[Frame]:
        """Advance to ``until_s`` at most one step; return the frames received meanwhile."""
        got: List[Frame] = []
        if self.simulated:
            if self.clock is not None:       # ``until_s`` is device time: one step of ``wall``
                self._advance(self.wall() + self.step_s)
            else:
                self._advance(min(until_s, self._now() + self.step_s))
            while (m := self.bus.recv(0.0)) is not None:
                got.append(self._take(m))
        else:
            timeout = 0.02 if self.clock is not None else max(0.0, min(until_s - self._now(), 0.05))
            m = self.bus.recv(timeout)
            while m is not None:
                got.append(self._take(m))
                self._beat()             # a long backlog must not hold the heartbeat back
                m = self.bus.recv(0.0)
        self._beat()
        return got

    def _going(self, end: float, wall_end: float) -> bool:
        if self._now() >= end:
            return False
        if self.clock is not None and self.wall() >= wall_end:
            return False
        return True

    def _last_look(self, end: float) -> List[Frame]:
        """A window ended: if it ended on its wall cap, take what the receive queue already holds.

        The cap is meant for devices that stand still. A host that is not scheduled at all for
        longer than the cap (CI's QEMU guest: 4–9 s gaps, docs/conformance.md) wakes past it with
        the devices' frames of that time already queued; giving up without reading them lost an
        SDO answer that came in time (a guest run's ``timing.sdo`` "No SDO response received").
        The frames are taken in order, so the devices' clock stamps each as usual and a caller can
        tell an answer inside the window (stamp ≤ ``end``) from a late one. Counted as a capped
        wait only if the devices' clock still stands before ``end`` after the look.
        """
        if self.clock is None or self._now() >= end:
            return []
        got = self._drain()
        if self._now() < end:
            self.capped_waits += 1          # the devices' clock stood still: reported
        return got

    def _ends(self, dt_s: float):
        """(end on the link's clock, end on the wall clock) of a window of ``dt_s``: on the
        devices' clock lengthened by its resolution and capped at ``dt / min_rate`` wall s."""
        if self.clock is None:
            return self._now() + dt_s, float("inf")
        dt_s += self.clock.resolution_s()
        return self._now() + dt_s, self.wall() + dt_s / self.min_rate + 1.0

    def wait(self, dt_s: float) -> List[Frame]:
        """Let ``dt_s`` of the link's time pass; return every frame received meanwhile."""
        end, wall_end = self._ends(dt_s)
        out: List[Frame] = []
        while self._going(end, wall_end):
            out.extend(self._poll(end))
        out.extend(self._last_look(end))
        return out

    def pump_until(self, pred: Callable[[Frame], bool], timeout_s: float) -> Optional[Frame]:
        """Wait until a received frame satisfies ``pred`` (returned) or ``timeout_s`` of the
        link's time has passed (None).

        Only a frame stamped inside the window counts: a host that reads a backlog takes frames
        the devices sent after the window in the same poll, and on the devices' clock a stamp is a
        lower bound of the frame's time, so a stamp past the end is truly late."""
        end, wall_end = self._ends(timeout_s)
        while self._going(end, wall_end):
            for f in self._poll(end):
                if f.t <= end and pred(f):  # a backlog read at once may run past the window
                    return f
        for f in self._last_look(end):
            if f.t <= end and pred(f):      # in the window on the devices' clock, read late
                return f
        return None

    def close(self) -> None:
        try:
            self.bus.shutdown()
        finally:
            if self._close is not None:
                self._close()


def open_real_link(interface: str, channel: str, bitrate: Optional[int] = None,
                   sdo_timeout_s: float = 0.1, device_clock: Optional[DeviceClock] = None,
                   min_rate: float = 0.05) -> Link:
    """A link on a python-can bus in real time (socketcan vcan0/can0, or any interface); its
    time is ``device_clock`` if given, else the wall clock.

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
    which = "the devices' clock" if device_clock is not None else "wall clock"
    return Link(bus, None, time.time, sdo_timeout_s=sdo_timeout_s, device_clock=device_clock,
                min_rate=min_rate, description=f"{interface} {channel} (real time; waits on {which})")
