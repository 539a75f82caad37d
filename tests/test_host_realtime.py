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
