"""Specification of bus.scheduler: one deterministic clock in integer microseconds."""

import pytest

from bus.errors import SchmidtFilError, SimulationError
from bus.scheduler import (PRIO_BACKGROUND, PRIO_CAN, PRIO_HOST, PRIO_ISR, PRIO_PLANT,
                           Scheduler)


def test_priority_constants_match_contract():
    """The PRIO_* constants have the values fixed in docs/architecture.md."""
    assert (PRIO_PLANT, PRIO_ISR, PRIO_CAN, PRIO_BACKGROUND, PRIO_HOST) == (0, 10, 20, 30, 40)


def test_call_at_runs_at_exact_time_and_passes_now():
    """call_at runs the callback at t_us and passes now_us to it."""
    s = Scheduler()
    seen = []
    s.call_at(1234, lambda now: seen.append((now, s.now_us)))
    s.run_until(1233)
    assert seen == []
    s.run_until(1234)
    assert seen == [(1234, 1234)]


def test_run_until_sets_now_to_end_time():
    """After run_until(t) the clock reads exactly t, even with no events."""
    s = Scheduler()
    s.run_until(10_000)
    assert s.now_us == 10_000


def test_call_later_is_relative_to_now():
    """call_later(d) runs at now_us + d."""
    s = Scheduler(start_us=500)
    seen = []
    s.call_later(100, seen.append)
    s.run_until(10_000)
    assert seen == [600]


def test_call_every_has_no_drift_and_defaults_to_one_period_from_now():
    """call_every fires at start + k*period exactly; default start is now + period."""
    s = Scheduler()
    seen = []
    s.call_every(5_000, seen.append)
    s.run_until(1_000_000)
    assert seen == list(range(5_000, 1_000_001, 5_000))


def test_call_every_with_start_us():
    """call_every(start_us=0) fires at time 0 first."""
    s = Scheduler()
    seen = []
    s.call_every(250_000, seen.append, start_us=0)
    s.run_until(500_000)
    assert seen == [0, 250_000, 500_000]


def test_equal_time_orders_by_priority_then_insertion():
    """At equal time, lower priority numbers run first; ties keep insertion order."""
    s = Scheduler()
    order = []
    s.call_at(100, lambda now: order.append("host"), PRIO_HOST)
    s.call_at(100, lambda now: order.append("can1"), PRIO_CAN)
    s.call_at(100, lambda now: order.append("plant"), PRIO_PLANT)
    s.call_at(100, lambda now: order.append("can2"), PRIO_CAN)
    s.call_at(100, lambda now: order.append("isr"), PRIO_ISR)
    s.run_until(100)
    assert order == ["plant", "isr", "can1", "can2", "host"]


def test_cancel_one_shot_and_periodic():
    """Cancelled events never run; a periodic event can cancel itself from its callback."""
    s = Scheduler()
    seen = []
    ev = s.call_at(10, seen.append)
    s.cancel(ev)
    ticks = []

    def tick(now):
        ticks.append(now)
        if len(ticks) == 3:
            s.cancel(every)

    every = s.call_every(10, tick)
    s.run_until(1000)
    assert seen == [] and ticks == [10, 20, 30]
    s.cancel(ev)  # cancelling twice is harmless


def test_callbacks_may_schedule_at_current_time():
    """An event scheduled for now from inside a callback runs in the same run_until."""
    s = Scheduler()
    seen = []
    s.call_at(50, lambda now: s.call_at(now, lambda n: seen.append(("inner", n))))
    s.run_until(50)
    assert seen == [("inner", 50)]


def test_step_runs_one_event():
    """step() runs exactly one event and returns False when nothing is left."""
    s = Scheduler()
    seen = []
    s.call_at(7, seen.append)
    s.call_at(3, seen.append)
    assert s.step() and seen == [3] and s.now_us == 3
    assert s.step() and seen == [3, 7]
    assert s.step() is False


def test_step_from_a_callback_is_refused_and_loses_no_event():
    """A re-entrant step() raises and leaves the pending event queued."""
    s = Scheduler()
    seen = []
    s.call_at(5, lambda now: s.step())
    s.call_at(9, seen.append)
    with pytest.raises(SimulationError, match="step called from inside a callback"):
        s.run_until(5)
    assert s.next_event_us() == 9
    s.run_until(10)
    assert seen == [9]


def test_exception_is_wrapped_with_owner_time_and_cause():
    """A callback's exception stops the run as SimulationError naming owner and now_us."""
    s = Scheduler()

    def boom(now):
        raise ZeroDivisionError("division by zero in PI update")

    s.call_at(5_000, boom, owner="ra-axis")
    with pytest.raises(SimulationError) as info:
        s.run_until(10_000)
    err = info.value
    assert err.owner == "ra-axis" and err.now_us == 5_000
    assert "ra-axis" in str(err) and "5000" in str(err)
    assert isinstance(err.__cause__, ZeroDivisionError)
    assert isinstance(err, SchmidtFilError)
    assert s.now_us == 5_000


def test_owner_defaults_to_callback_name():
    """Without owner=, the error names the callback's qualified name."""
    s = Scheduler()

    def isr_tick(now):
        raise RuntimeError("x")

    s.call_later(1, isr_tick)
    with pytest.raises(SimulationError, match="isr_tick"):
        s.run_until(2)


def test_scheduling_in_the_past_or_with_float_time_is_refused():
    """Times are integer µs and never in the past."""
    s = Scheduler(start_us=100)
    with pytest.raises(SimulationError):
        s.call_at(99, print)
    with pytest.raises(TypeError):
        s.call_at(100.5, print)
    with pytest.raises(SimulationError):
        s.run_until(50)


def test_determinism():
    """Two identical schedules produce identical traces."""
    def trace():
        s = Scheduler()
        out = []
        for i in range(5):
            s.call_every(1000 + 7 * i, lambda now, i=i: out.append((now, i)), priority=i % 2)
        s.run_until(50_000)
        return out

    assert trace() == trace()


# -- the heap against a reference it shares no code with --------------------------------------
from hypothesis import given, settings, strategies as st  # noqa: E402


class _ReferenceClock:
    """The ordering contract written as the plainest possible code: a list, scanned for the
    minimum ``(t_us, priority, insertion number)`` at every step (no heap)."""

    def __init__(self):
        self.now_us = 0
        self.items = []           # [t_us, priority, seq, key, period_us, cancelled]
        self.seq = 0

    def add(self, t_us, priority, key, period_us):
        self.seq += 1
        item = [t_us, priority, self.seq, key, period_us, False]
        self.items.append(item)
        return item

    def step(self, on_run, end_us=None):
        """Run the earliest live item (none later than ``end_us``); False if there is none."""
        live = [i for i in self.items if not i[5]]
        if not live:
            return False
        first = min(live, key=lambda i: (i[0], i[1], i[2]))
        if end_us is not None and first[0] > end_us:
            return False
        self.now_us = first[0]
        if first[4] is None:
            first[5] = True
        else:                     # next repetition queued before the callback, new seq
            self.seq += 1
            first[0] += first[4]
            first[2] = self.seq
        on_run(first)
        return True

    def run_until(self, end_us, on_run):
        while self.step(on_run, end_us):
            pass
        self.now_us = end_us


_op = st.tuples(st.integers(0, 400), st.integers(0, 3), st.sampled_from([None, 7, 50, 130]),
                st.integers(0, 9))


@settings(max_examples=150, deadline=None)
@given(st.lists(_op, min_size=1, max_size=60), st.lists(st.integers(1, 900), min_size=1, max_size=6))
def test_order_matches_a_reference_without_a_heap(ops, ends):
    """Random one-shot and periodic events at colliding times and priorities; callbacks that
    cancel other events and schedule new ones at the current instant: the scheduler runs the
    same (key, time) sequence as the reference."""
    s, ref = Scheduler(), _ReferenceClock()
    seen, seen_ref = [], []
    events, ref_items = {}, {}

    def plan(idx, now_us):
        # what the callback of op ``idx`` does at ``now_us``: cancel op ``c``, maybe add one
        t_off, prio, period, c = ops[idx]
        return c, (idx * 7 + now_us) % 5 == 0

    def make_cb(idx):
        def cb(now_us):
            seen.append((idx, now_us))
            c, spawn = plan(idx, now_us)
            if c in events:
                s.cancel(events[c])
            if spawn and len(events) < 200:
                k = 1000 + len(events)
                events[k] = s.call_at(now_us, lambda t, k=k: seen.append((k, t)), priority=3)
        return cb

    def ref_run(item):
        idx, t = item[3], ref.now_us
        seen_ref.append((idx, t))
        if idx >= 1000:
            return
        c, spawn = plan(idx, t)
        if c in ref_items:
            ref_items[c][5] = True
        if spawn and len(ref_items) < 200:
            k = 1000 + len(ref_items)
            ref_items[k] = ref.add(t, 3, k, None)

    for idx, (t_off, prio, period, _) in enumerate(ops):
        if period is None:
            events[idx] = s.call_at(t_off, make_cb(idx), priority=prio)
        else:
            events[idx] = s.call_every(period, make_cb(idx), start_us=t_off, priority=prio)
        ref_items[idx] = ref.add(t_off, prio, idx, period)
    end = 0
    for step in ends:
        end += step
        s.run_until(end)
        ref.run_until(end, ref_run)
        assert seen == seen_ref
        assert s.now_us == ref.now_us == end
    assert s.pending() == sum(1 for i in ref.items if not i[5])


# -- timer groups (bus.scheduler.TimerGroup) against the same reference ------------------------
# what a callback does: cancel another event; queue a one-shot (at this instant or one period of
# its own ahead, at a drawn priority); start a new periodic event (same period, due one period on)
_act = st.tuples(st.integers(0, 12), st.sampled_from(["none", "now", "period", "every"]), st.integers(0, 3))
_grp_op = st.tuples(st.sampled_from([0, 0, 10, 20, 35]), st.integers(0, 3),
                    st.sampled_from([None, 10, 10, 20, 35]), _act)


@settings(max_examples=300, deadline=None)
@given(st.lists(_grp_op, min_size=2, max_size=40),
       st.lists(st.one_of(st.integers(1, 120), st.just(0)), min_size=1, max_size=10))
def test_timer_groups_keep_the_order_of_events_one_by_one(ops, ends):
    """Many periodic events share a (period, phase, priority) and so a TimerGroup; their
    callbacks cancel events, queue one-shots at this instant and exactly one period ahead at
    every priority (the cases that split a group), and start new periodic events that join
    groups; ``0`` in ``ends`` is a ``step()``. The order of (event, time) and ``pending()`` match
    a reference that keeps every event on its own, with no groups and no heap."""
    s, ref = Scheduler(), _ReferenceClock()
    seen, seen_ref = [], []
    events, ref_items = {}, {}
    limit = 120

    def action(idx, now_us):
        tgt, what, prio = ops[idx % len(ops)][3]
        return tgt, ((what if (idx + now_us // 5) % 3 else "none") if idx < 1000 else "none"), prio

    def make_cb(idx, period):
        def cb(now_us):
            seen.append((idx, now_us))
            tgt, what, prio = action(idx, now_us)
            if tgt in events:
                s.cancel(events[tgt])
            if len(events) >= limit or what == "none":
                return
            k = 1000 + len(events) if what != "every" else 2000 + len(events)
            if what == "now":
                events[k] = s.call_at(now_us, make_cb(k, None), priority=prio)
            elif what == "period" and period:
                events[k] = s.call_at(now_us + period, make_cb(k, None), priority=prio)
            elif what == "every" and period:
                events[k] = s.call_every(period, make_cb(k, period), priority=ops[idx % len(ops)][1])
        return cb

    def ref_run(item):
        idx, t = item[3], ref.now_us
        seen_ref.append((idx, t))
        tgt, what, prio = action(idx, t)
        if tgt in ref_items:
            ref_items[tgt][5] = True
        if len(ref_items) >= limit or what == "none":
            return
        k = 1000 + len(ref_items) if what != "every" else 2000 + len(ref_items)
        own = item[4]
        if what == "now":
            ref_items[k] = ref.add(t, prio, k, None)
        elif what == "period" and own:
            ref_items[k] = ref.add(t + own, prio, k, None)
        elif what == "every" and own:
            ref_items[k] = ref.add(t + own, ops[idx % len(ops)][1], k, own)

    for idx, (t0, prio, period, _) in enumerate(ops):
        if period is None:
            events[idx] = s.call_at(t0, make_cb(idx, None), priority=prio)
        else:
            events[idx] = s.call_every(period, make_cb(idx, period), start_us=t0, priority=prio)
        ref_items[idx] = ref.add(t0, prio, idx, period)
    end = 0
    for step in ends:
        if step == 0:
            assert s.step() == ref.step(ref_run)
            end = s.now_us
        else:
            end = max(end, s.now_us) + step
            s.run_until(end)
            ref.run_until(end, ref_run)
            assert s.now_us == ref.now_us == end
        assert seen == seen_ref
        assert s.pending() == sum(1 for i in ref.items if not i[5])


def test_timer_group_shares_one_heap_entry_and_counts_every_member():
    """Six 5 ms timers of one phase and priority are one heap entry; ``events_run`` and
    ``pending()`` count them one by one; a cancelled member stops, the others go on."""
    s = Scheduler()
    seen = []
    evs = [s.call_every(5_000, lambda now, i=i: seen.append((now, i)), priority=10) for i in range(6)]
    assert len(s._heap) == 1 and s.pending() == 6
    s.run_until(10_000)
    assert seen == [(t, i) for t in (5_000, 10_000) for i in range(6)]
    assert s.events_run == 12
    s.cancel(evs[2])
    s.run_until(15_000)
    assert [i for t, i in seen if t == 15_000] == [0, 1, 3, 4, 5] and s.pending() == 5
    assert all(ev.t_us == 20_000 for ev in evs if not ev.cancelled)   # Timer.ticks reads this


@pytest.mark.parametrize("what", ["one-shot", "periodic"])
def test_timer_group_split_by_an_event_queued_one_period_ahead(what):
    """A member queues an event for exactly the group's next time and priority: one by one, that
    event runs before the members that had not yet run; the group splits to keep that order."""
    s = Scheduler()
    seen = []

    def first(now):
        seen.append((now, "a"))
        if now == 5_000:
            if what == "one-shot":
                s.call_at(now + 5_000, lambda t: seen.append((t, "e")), priority=10)
            else:
                s.call_every(5_000, lambda t: seen.append((t, "x")), priority=10)

    s.call_every(5_000, first, priority=10)
    s.call_every(5_000, lambda t: seen.append((t, "b")), priority=10)
    s.call_every(5_000, lambda t: seen.append((t, "c")), priority=10)
    s.run_until(15_000)
    new = "e" if what == "one-shot" else "x"
    assert seen == [(5_000, "a"), (5_000, "b"), (5_000, "c"),
                    (10_000, "a"), (10_000, new), (10_000, "b"), (10_000, "c"),
                    (15_000, "a")] + ([(15_000, "x")] if what == "periodic" else []) + [(15_000, "b"), (15_000, "c")]


def test_timer_group_split_by_an_earlier_event_at_this_instant():
    """A member queues an event at this instant with a lower priority number: it runs before the
    members that had not yet run, as one by one."""
    s = Scheduler()
    seen = []

    def first(now):
        seen.append((now, "a"))
        s.call_at(now, lambda t: seen.append((t, "isr")), priority=0)

    s.call_every(5_000, first, priority=30)
    s.call_every(5_000, lambda t: seen.append((t, "b")), priority=30)
    s.run_until(10_000)
    assert seen == [(5_000, "a"), (5_000, "isr"), (5_000, "b"), (10_000, "a"), (10_000, "isr"), (10_000, "b")]
