"""The one simulated clock: a deterministic discrete-event scheduler in integer microseconds.

Everything time-dependent in schmidt-fil (board timers, CAN frame ends, plant integration,
host scenarios) is an event on one :class:`Scheduler`. Nothing reads the wall clock, sleeps or
starts a thread.

Ordering is total and deterministic: events are ordered by ``(t_us, priority, seq)``; at equal
time a lower ``priority`` number runs first, and ``seq`` (insertion order) breaks the remaining
ties. Two runs of the same scenario therefore execute the same callbacks in the same order.

Periodic events of one period, phase and priority (a board's timers: the 5 ms ISRs, the
background loops, the heartbeats) share one heap entry, a :class:`TimerGroup`, which runs them in
the order they would run one by one; the rule above holds exactly (the class docstring says how).

The queue is a binary heap of the :class:`Event` objects themselves, ordered by those three
integer fields (:func:`_sift_down` / :func:`_sift_up`: the algorithm of :mod:`heapq`), not a
:mod:`heapq` of tuples. Compiled (``bus/_native.py``), its comparisons are C compares of the
events' integer fields and nothing is allocated per event; ``heapq`` built a 4-tuple per push
and compared tuples item by item, through the generic call and comparison protocols (≈ 7 % of
the ``full`` network's time, docs/performance.md, session 8). Interpreted (``SCHMIDT_FIL_NATIVE=0``)
this heap is slower than ``heapq``'s C; the compiled build is the one that has to be fast.

Examples
--------
>>> s = Scheduler()
>>> seen = []
>>> ev = s.call_every(5_000, seen.append, owner="tick")
>>> s.run_until(20_000)
>>> seen
[5000, 10000, 15000, 20000]
"""

from __future__ import annotations

from operator import index as _index
from typing import Any, Callable, Final, Optional

from bus.errors import SimulationError

__all__ = [
    "Scheduler",
    "Event",
    "PRIO_PLANT",
    "PRIO_ISR",
    "PRIO_CAN",
    "PRIO_BACKGROUND",
    "PRIO_HOST",
    "PRIO_ARBITRATION",
]

#: Plant integration runs first at a given instant, so sensors read the state at ``now_us``.
PRIO_PLANT: Final = 0
#: Board timer interrupts (the 5 ms control tick).
PRIO_ISR: Final = 10
#: CAN frame completion and receive interrupts.
PRIO_CAN: Final = 20
#: Board background loops (command parsing, housekeeping).
PRIO_BACKGROUND: Final = 30
#: Host-side scenario steps and logging.
PRIO_HOST: Final = 40
#: CAN arbitration on an idle bus: after every other event of the same µs, so that every frame
#: submitted at that µs — by a timer ISR, a background loop, a receive handler or the host —
#: competes, and the lowest identifier wins, as on a real bus where all of them are ready before
#: the start-of-frame bit (ISO 11898-1 bitwise arbitration; the model: ``bus/network.py`` docstring,
#: docs/architecture.md). The arbitration that follows a completed frame runs inline at
#: ``PRIO_CAN``, among the frames pending at that moment.
PRIO_ARBITRATION: Final = 50

Callback = Callable[[int], object]


class Event:
    """A scheduled callback; returned by ``call_*`` and accepted by :meth:`Scheduler.cancel`.

    Attributes
    ----------
    t_us : int
        Time of the next run, µs.
    priority : int
        Lower runs first at equal ``t_us``.
    callback : callable
        Called as ``callback(now_us)``.
    owner : str or None
        Who scheduled it (for error messages), e.g. ``"ra-axis"``.
    period_us : int or None
        Repeat period for :meth:`Scheduler.call_every`, else ``None``.
    cancelled : bool
        True once cancelled (or once a one-shot event has run).
    seq : int
        Insertion number of its current place in the queue (breaks ties of ``t_us`` and
        ``priority``).
    queued : bool
        True while it is in the scheduler's heap (a cancelled event stays there until its time);
        a member of a timer group is queued through its group's entry.
    group : TimerGroup or None
        On the heap entry of a timer group (see :class:`TimerGroup`): the group. None on every
        event returned to a caller.
    """

    __slots__ = ("t_us", "priority", "seq", "callback", "owner", "period_us", "cancelled", "queued", "group")

    def __init__(self, t_us: int, priority: int, callback: Callback, owner: str | None,
                 period_us: int | None) -> None:
        self.t_us = t_us
        self.priority = priority
        self.seq = 0
        self.callback = callback
        self.owner = owner
        self.period_us = period_us
        self.cancelled = False
        self.queued = False
        self.group: Optional[TimerGroup] = None   # set on the heap entry of a timer group

    def describe_owner(self) -> str:
        """Return the owner string, or the callback's qualified name when no owner was given."""
        if self.owner is not None:
            return self.owner
        cb = self.callback
        return getattr(cb, "__qualname__", None) or repr(cb)

    def __repr__(self) -> str:
        rep = f" every {self.period_us} µs" if self.period_us else ""
        state = " cancelled" if self.cancelled else ""
        return f"<Event {self.describe_owner()} at {self.t_us} µs prio {self.priority}{rep}{state}>"


def _sift_down(heap: list[Event], start: int, pos: int) -> None:
    """Move ``heap[pos]`` towards the root (not above ``start``) until its parent runs before
    it (``heapq._siftdown``)."""
    item = heap[pos]
    # does item run before parent? ``(t_us, priority, seq)`` compared in that order, written out
    # here and in _sift_up instead of a helper (a native call per comparison, session 16)
    t = item.t_us
    prio = item.priority
    seq = item.seq
    while pos > start:
        parent_pos = (pos - 1) >> 1
        parent = heap[parent_pos]
        pt = parent.t_us
        if t < pt or (t == pt and (prio < parent.priority or (prio == parent.priority and seq < parent.seq))):
            heap[pos] = parent
            pos = parent_pos
            continue
        break
    heap[pos] = item


def _sift_up(heap: list[Event], pos: int) -> None:
    """Restore the heap below ``pos`` after ``heap[pos]`` changed to a later key: move the
    earlier child up to a leaf, then sift the item back (``heapq._siftup``, fewer comparisons
    than stopping early)."""
    end = len(heap)
    start = pos
    item = heap[pos]
    child = 2 * pos + 1
    while child < end:
        right = child + 1
        if right < end:
            # the right child runs first? (keys are unique, so "not child first" is the same)
            c = heap[child]
            r = heap[right]
            if r.t_us < c.t_us or (r.t_us == c.t_us and (r.priority < c.priority
                                                         or (r.priority == c.priority and r.seq < c.seq))):
                child = right
        heap[pos] = heap[child]
        pos = child
        child = 2 * pos + 1
    heap[pos] = item
    _sift_down(heap, start, pos)


def _heap_pop(heap: list[Event]) -> Event:
    """Remove and return the earliest event of a non-empty heap; it is no longer ``queued``."""
    last = heap.pop()
    if heap:
        first = heap[0]
        heap[0] = last
        _sift_up(heap, 0)
    else:
        first = last
    first.queued = False
    return first


class TimerGroup:
    """Periodic events of one period, phase and priority that fire one after another: one heap entry.

    A board's timers share a few periods and phases (the 5 ms ISRs of the axis controllers and
    tachometers, their background loops, the 10 ms readers, the 1 s heartbeats: docs/performance.md,
    "Session 23"). Scheduled one by one, each of them was popped from and sifted back into the heap
    at every period. A group is one heap entry that runs its members in the order they would have
    run one by one, so the order of every callback is unchanged — the ordering rule of the module
    docstring still holds exactly:

    * members fire in the order they joined, and a periodic event joins a group only when no other
      event of the same time and priority was queued after the group's entry
      (:meth:`Scheduler.call_every`);
    * while a member runs, an event queued to run before the next member at this instant (same
      time, lower priority number) or between the group and the next member at the next period
      (the group's next time and priority) splits the members not yet run into a new group, queued
      exactly where they stood one by one (:meth:`_split_off`); so does :meth:`Scheduler.step`,
      which runs one member, and an exception in a member;
    * a cancelled member is skipped and dropped; an empty group cancels its entry.

    ``tests/test_bus_scheduler.py`` checks the order against a reference clock that keeps every
    event on its own (random events, periods, priorities, cancellations, and callbacks that queue
    events at this instant and one period ahead).
    """

    def __init__(self, scheduler: "Scheduler", period_us: int, priority: int, key: tuple[int, int, int]) -> None:
        self.scheduler = scheduler
        self.period_us = period_us
        self.priority = priority
        self.key = key
        self.members: list[Event] = []
        self.event = Event(0, priority, self.fire, None, period_us)
        self.event.group = self
        self.sched_seq = 0           # the entry's seq for the firing it is queued for
        self.split = False           # set by Scheduler._note_push while a member runs
        self.step_once = False       # set by Scheduler.step: run one member, split off the rest

    def live(self) -> int:
        """Number of members not cancelled."""
        return sum(1 for m in self.members if not m.cancelled)

    def fire(self, t: int) -> None:
        """Run the members due at ``t`` (the entry is already queued for ``t + period_us``)."""
        s = self.scheduler
        base_seq = self.sched_seq
        self.sched_seq = self.event.seq
        members = self.members
        n = len(members)
        period = self.period_us
        nxt = t + period
        s._firing = self
        self.split = False
        once = self.step_once
        self.step_once = False
        i = 0
        ran = 0
        dead = 0
        try:
            while i < n:
                m = members[i]
                i += 1
                if m.cancelled:
                    dead += 1
                    continue
                m.t_us = nxt
                ran += 1
                try:
                    m.callback(t)
                except SimulationError:
                    self._split_off(i, n, t, base_seq)
                    raise
                except Exception as exc:
                    self._split_off(i, n, t, base_seq)
                    raise s._wrap(m, exc)
                if (self.split or once) and i < n:
                    self._split_off(i, n, t, base_seq)
                    break
        finally:
            s._firing = None
            s.events_run += ran - 1      # the entry was counted as one event
        if dead:
            self.members = [m for m in self.members if not m.cancelled]
            if not self.members:
                self.event.cancelled = True
                if s._heads.get(self.key) is self.event:
                    del s._heads[self.key]

    def _split_off(self, i: int, n: int, t: int, base_seq: int) -> None:
        """Move the members ``i … n−1`` (not yet run at ``t``) into a new group queued at ``t``
        with this firing's seq: where they stood, one by one, before this group ran."""
        rest = [m for m in self.members[i:n] if not m.cancelled]
        self.members = self.members[:i] + self.members[n:]
        if not rest:
            return
        s = self.scheduler
        g = TimerGroup(s, self.period_us, self.priority, self.key)
        g.members = rest
        ev = g.event
        ev.t_us = t
        ev.seq = base_seq
        g.sched_seq = base_seq
        ev.queued = True
        heap = s._heap
        heap.append(ev)
        _sift_down(heap, 0, len(heap) - 1)


class Scheduler:
    """Deterministic event scheduler; the single owner of simulated time.

    Parameters
    ----------
    start_us : int, optional
        Initial value of :attr:`now_us`, µs (default 0).

    Attributes
    ----------
    now_us : int
        Current simulated time, integer µs. Advanced only by :meth:`run_until` and :meth:`step`.
    events_run : int
        Number of callbacks executed so far (for benchmarks).

    Notes
    -----
    Times and periods given to the public methods may be any integer type (``int``,
    ``numpy.int64``: anything with ``__index__``; floats are refused with ``TypeError``). They
    are annotated ``Any`` so that the compiled build (``bus/_native.py``) accepts exactly what
    the source accepts and converts with ``operator.index``.
    """

    def __init__(self, start_us: Any = 0) -> None:
        self.now_us: int = _index(start_us)
        self.events_run = 0
        self._heap: list[Event] = []
        self._seq = 0
        self._running = False
        # (period, phase, priority) → the heap entry last queued for it: a lone periodic event
        # or a TimerGroup's entry (call_every)
        self._heads: dict[tuple[int, int, int], Event] = {}
        self._firing: Optional[TimerGroup] = None

    # -- scheduling -------------------------------------------------------------------------
    def call_at(self, t_us: Any, callback: Callback, priority: int = 0, *,
                owner: str | None = None) -> Event:
        """Run ``callback(now_us)`` once at absolute time ``t_us``.

        Parameters
        ----------
        t_us : int
            Absolute time, µs; must be ``>= now_us`` and an integer (floats are refused).
        callback : callable
            ``callback(now_us: int)``.
        priority : int, optional
            Lower runs first at equal time (use the ``PRIO_*`` constants).
        owner : str, optional
            Named in :class:`~bus.errors.SimulationError` if the callback raises.

        Returns
        -------
        Event

        Raises
        ------
        TypeError
            If ``t_us`` is not an integer.
        SimulationError
            If ``t_us`` is in the past.
        """
        t_us = _index(t_us)
        if t_us < self.now_us:
            raise SimulationError(
                f"cannot schedule {owner or getattr(callback, '__qualname__', callback)} at "
                f"{t_us} µs: it is already {self.now_us} µs", owner, self.now_us)
        ev = Event(t_us, priority, callback, owner, None)
        self._push(ev)
        return ev

    def call_later(self, delay_us: Any, callback: Callback, priority: int = 0, *,
                   owner: str | None = None) -> Event:
        """Run ``callback(now_us)`` once, ``delay_us`` (integer µs, ``>= 0``) from now."""
        delay_us = _index(delay_us)
        if delay_us < 0:
            raise SimulationError(f"negative delay {delay_us} µs", owner, self.now_us)
        return self.call_at(self.now_us + delay_us, callback, priority, owner=owner)

    def call_every(self, period_us: Any, callback: Callback, *, start_us: Any = None,
                   priority: int = 0, owner: str | None = None) -> Event:
        """Run ``callback(now_us)`` at ``start_us + k * period_us`` for k = 0, 1, 2, ...

        Parameters
        ----------
        period_us : int
            Period, integer µs, ``> 0``. Times are exact multiples: no drift.
        callback : callable
            ``callback(now_us: int)``.
        start_us : int, optional
            Time of the first run, µs; default ``now_us + period_us`` (a hardware timer first
            fires one period after it is started).
        priority : int, optional
            Lower runs first at equal time.
        owner : str, optional
            Named in errors.

        Returns
        -------
        Event
            The same object for every repetition; :meth:`cancel` stops the series, also from
            inside the callback.

        Notes
        -----
        The next repetition is queued *before* the callback runs, so events the callback
        schedules for the same future instant (same priority) run after it.

        Periodic events of the same period, phase and priority share one heap entry
        (:class:`TimerGroup`); the order of callbacks is the same as if each had its own.
        """
        period_us = _index(period_us)
        if period_us <= 0:
            raise SimulationError(f"period must be > 0 µs, got {period_us}", owner, self.now_us)
        t_us = self.now_us + period_us if start_us is None else _index(start_us)
        if t_us < self.now_us:
            raise SimulationError(f"start {t_us} µs is before now ({self.now_us} µs)",
                                  owner, self.now_us)
        ev = Event(t_us, priority, callback, owner, period_us)
        # one heap entry per (period, phase, priority): a lone periodic event, turned into a
        # TimerGroup when a second one joins it — only where the order one by one is kept (no
        # event of the same time and priority queued after it)
        key = (period_us, priority, t_us % period_us)
        head = self._heads.get(key)
        if (head is None or head.t_us != t_us or head.cancelled or not head.queued
                or not self._may_join(head)):
            self._push(ev)
            self._heads[key] = ev
            return ev
        g = head.group
        if g is None:                    # the lone event becomes a group's first member
            g = TimerGroup(self, period_us, priority, key)
            g.members.append(head)
            gev = g.event
            gev.t_us = head.t_us
            gev.seq = head.seq
            g.sched_seq = head.seq
            gev.queued = True
            heap = self._heap
            heap[heap.index(head)] = gev  # same (t_us, priority, seq): the heap stays ordered
            self._heads[key] = gev
        self._seq += 1                   # the seq it would have had: numbering as one by one
        self._note_push(t_us, priority)
        g.members.append(ev)
        ev.seq = g.event.seq
        ev.queued = True
        return ev

    def _may_join(self, head: Event) -> bool:
        """True if no event of ``head``'s time and priority was queued after ``head`` (a scan
        of the heap: joins happen when timers start, not per event)."""
        t, prio, seq = head.t_us, head.priority, head.seq
        for e in self._heap:
            if e.t_us == t and e.priority == prio and e.seq > seq:
                return False
        return True

    def _note_push(self, t_us: int, priority: int) -> None:
        """While a group's member runs: an event queued before its next member at this instant, or
        between the group and its next member one period on, splits the group (:class:`TimerGroup`)."""
        f = self._firing
        if f is not None:
            if t_us == self.now_us:
                if priority < f.priority:
                    f.split = True
            elif t_us == f.event.t_us and priority == f.priority:
                f.split = True

    def _call_at_trusted(self, t_us: int, callback: Callback, priority: int, owner: str | None) -> Event:
        """:meth:`call_at` without its checks, for the simulator's own hot paths (the CAN
        network schedules two events per frame) that pass an ``int`` ``t_us >= now_us``."""
        ev = Event(t_us, priority, callback, owner, None)
        self._push(ev)
        return ev

    def _reschedule_trusted(self, ev: Event, t_us: int) -> None:
        """Queue a spent one-shot ``ev`` (it ran, so ``ev.cancelled`` is True) again at ``t_us``,
        as :meth:`_call_at_trusted` with the same callback, priority and owner would, without
        building a new :class:`Event` (the CAN network's per-frame events).

        Raises
        ------
        SimulationError
            If ``ev`` is still queued (cancelled before its time came): its place in the heap
            depends on its time, which must not change there.
        """
        if ev.queued:
            raise SimulationError(f"cannot reschedule {ev.describe_owner()}: it is still queued",
                                  ev.owner, self.now_us)
        ev.t_us = t_us
        ev.cancelled = False
        self._push(ev)

    def cancel(self, event: Optional[Event]) -> None:
        """Cancel ``event`` (one-shot or periodic). Cancelling twice, after it ran, or ``None``
        is a no-op."""
        if event is not None:
            event.cancelled = True

    def _push(self, ev: Event) -> None:
        self._seq += 1
        ev.seq = self._seq
        ev.queued = True
        if self._firing is not None:
            self._note_push(ev.t_us, ev.priority)
        heap = self._heap
        heap.append(ev)
        _sift_down(heap, 0, len(heap) - 1)

    # -- running ----------------------------------------------------------------------------
    def next_event_us(self) -> int | None:
        """Time of the next pending (non-cancelled) event, µs, or ``None`` if there is none."""
        heap = self._heap
        while heap:
            top = heap[0]
            g = top.group
            if top.cancelled or (g is not None and not g.live()):
                _heap_pop(heap)
                top.cancelled = True
                if g is not None and self._heads.get(g.key) is top:
                    del self._heads[g.key]
                continue
            break
        return heap[0].t_us if heap else None

    def pending(self) -> int:
        """Number of queued, non-cancelled events (each member of a timer group counted)."""
        n = 0
        for ev in self._heap:
            if not ev.cancelled:
                g = ev.group
                n += 1 if g is None else g.live()
        return n

    def run_until(self, t_us: Any) -> None:
        """Run every event with time ``<= t_us`` in order, then set ``now_us = t_us``.

        Parameters
        ----------
        t_us : int
            Absolute end time, µs, ``>= now_us``.

        Raises
        ------
        SimulationError
            If a callback raises (the original exception is ``__cause__``; ``now_us`` stays at
            the failing event's time), if ``t_us`` is in the past, or if called re-entrantly
            from inside a callback.
        """
        end_us: int = _index(t_us)       # typed: the loop compares native ints
        if end_us < self.now_us:
            raise SimulationError(f"run_until({end_us}) is before now ({self.now_us} µs)",
                                  None, self.now_us)
        if self._running:
            raise SimulationError("run_until called from inside a callback", None, self.now_us)
        heap = self._heap
        self._running = True
        n = 0
        try:
            while heap:
                ev = heap[0]
                t = ev.t_us
                if t > end_us:
                    break
                if ev.cancelled:
                    _heap_pop(heap)
                    continue
                self.now_us = t
                period = ev.period_us
                if period is None:
                    _heap_pop(heap)
                    ev.cancelled = True  # a one-shot event is spent once it runs
                else:
                    # the next repetition takes this entry's place: one sift instead of pop +
                    # push (keys are unique, so the order of events is the same either way)
                    ev.t_us = t + period
                    self._seq += 1
                    ev.seq = self._seq
                    _sift_up(heap, 0)
                n += 1
                try:
                    ev.callback(t)
                except SimulationError:
                    raise
                except Exception as exc:
                    raise self._wrap(ev, exc)
            self.now_us = end_us
        finally:
            self._running = False
            self.events_run += n

    def step(self) -> bool:
        """Run the next pending event (advancing ``now_us`` to its time).

        Returns
        -------
        bool
            False if there was nothing to run.
        """
        if self._running:  # checked before popping: a refused step must not lose the event
            raise SimulationError("step called from inside a callback", None, self.now_us)
        t = self.next_event_us()
        if t is None:
            return False
        # Exactly one event, with run_until's semantics. run_until inlines the same steps in its
        # loop on purpose: it is the simulator's hot loop (a call per event costs ~10 %).
        ev = _heap_pop(self._heap)
        self.now_us = t
        if ev.period_us is None:
            ev.cancelled = True
        else:
            ev.t_us = t + ev.period_us
            self._push(ev)
            if ev.group is not None:
                ev.group.step_once = True    # one member; the rest split off, queued where they stood
        self.events_run += 1
        self._running = True
        try:
            ev.callback(t)
        except SimulationError:
            raise
        except Exception as exc:
            raise self._wrap(ev, exc)
        finally:
            self._running = False
        return True

    def _wrap(self, ev: Event, exc: Exception) -> SimulationError:
        owner = ev.describe_owner()
        err = SimulationError(
            f"{owner} raised {type(exc).__name__}: {exc} at t = {self.now_us} µs",
            owner, self.now_us)
        # ``raise err from exc``, spelled out: compiled by mypyc, ``raise ... from`` does not set
        # the cause (tests/test_bus_scheduler.py checks it)
        err.__cause__ = exc
        err.__suppress_context__ = True
        return err
