"""The real-time pacer holds simulated time to the wall clock and reports lateness."""

import host.realtime as rt


class FakeClock:
    def __init__(self):
        self.t = 100.0
        self.slept = []

    def monotonic(self):
        return self.t

    def sleep(self, s):
        self.slept.append(s)
        self.t += s


def test_pacer_sleeps_to_absolute_deadlines_and_records_lateness(monkeypatch):
    """Early: sleep exactly to the deadline. Late: no sleep, lateness recorded in µs."""
    clk = FakeClock()
    monkeypatch.setattr(rt.time, "monotonic", clk.monotonic)
    monkeypatch.setattr(rt.time, "sleep", clk.sleep)
    p = rt.RealtimePacer(start_sim_us=1_000_000)
    p.wait_for(1_005_000)                 # 5 ms of simulated time ahead
    assert len(clk.slept) == 1 and abs(clk.slept[0] - 0.005) < 1e-9 and abs(clk.t - 100.005) < 1e-9
    clk.t += 0.020                         # the host stalls 20 ms (a VM stall)
    p.wait_for(1_010_000)                  # deadline was 100.010 -> 15 ms late
    assert len(clk.slept) == 1
    s = p.stats()
    assert s["late_steps"] == 1 and abs(s["max_late_us"] - 15_000) <= 1


def test_pacer_runs_a_scheduler_step_by_step_behind_the_wall_clock(monkeypatch):
    """run_until advances the scheduler in step_us steps, each only after its wall-clock time;
    stats count the steps and give the achieved real-time factor (1.0 when it kept up)."""
    from bus.scheduler import Scheduler

    clk = FakeClock()
    monkeypatch.setattr(rt.time, "monotonic", clk.monotonic)
    monkeypatch.setattr(rt.time, "sleep", clk.sleep)
    sched = Scheduler()
    seen = []
    sched.call_every(5_000, lambda now: seen.append((now, round(clk.t - 100.0, 6))), start_us=0)
    p = rt.RealtimePacer(start_sim_us=0)
    p.run_until(sched, 20_000)
    assert sched.now_us == 20_000
    # each step runs when the wall clock reaches its end: an event never runs before its time on
    # the wall clock, and at most one step after it
    assert seen == [(0, 0.005), (5_000, 0.005), (10_000, 0.01), (15_000, 0.015), (20_000, 0.02)]
    s = p.stats()
    assert s["steps"] == 4 and s["late_steps"] == 0 and s["realtime_factor"] == 1.0
    clk.t += 0.012                          # a 12 ms stall: the next two steps are 7 and 2 ms late
    p.run_until(sched, 30_000)
    s = p.stats()
    assert s["steps"] == 6 and s["late_steps"] == 2 and abs(s["max_late_us"] - 7_000) <= 1
    assert s["realtime_factor"] == round(0.030 / 0.032, 4)    # 30 ms simulated in 32 ms
