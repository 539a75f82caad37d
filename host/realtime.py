"""Real-time pacing of the simulated clock, for runs on a real bus (SocketCAN ``vcan0``/``can0``).

The scheduler still owns simulated time; the pacer only holds the run back so that simulated
time does not get ahead of the wall clock, sleeping to absolute deadlines (FACTS.md: lateness
p50 ≈ 0.1 ms, p99 0.25–0.5 ms, with 15–45 ms VM stalls every few seconds). It never runs the
simulation faster to "catch up" silently: lateness is measured and reported, as SimPy's
real-time environment raises when it falls behind. Boards and plant never see the wall clock.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

__all__ = ["RealtimePacer"]


@dataclass
class RealtimePacer:
    """Hold simulated time to the wall clock.

    Parameters
    ----------
    start_sim_us : int
        Simulated time at the wall-clock origin [µs].
    step_us : int
        Pacing granularity [µs] (the axis controllers' 5 ms tick by default).
    """

    start_sim_us: int
    step_us: int = 5_000
    late_us: list = field(default_factory=list)
    steps: int = 0

    def __post_init__(self) -> None:
        self._wall0 = time.monotonic()
        self._sim_last_us = self.start_sim_us
        self._wall_last = self._wall0

    def wait_for(self, sim_us: int) -> None:
        """Sleep until the wall clock reaches simulated time ``sim_us``; record lateness."""
        deadline = self._wall0 + (sim_us - self.start_sim_us) / 1e6
        now = time.monotonic()
        self.steps += 1
        self._sim_last_us = sim_us
        if now < deadline:
            time.sleep(deadline - now)
            self._wall_last = deadline
        else:
            self.late_us.append(int((now - deadline) * 1e6))
            self._wall_last = now

    def run_until(self, scheduler, t_us: int) -> None:
        """Run ``scheduler`` to ``t_us`` in steps of ``step_us``, each no earlier than the wall
        clock allows (what the runner's main loop does; the host's health check uses it so that
        its answer window is wall-clock time on a real bus)."""
        while scheduler.now_us < t_us:
            nxt = min(t_us, scheduler.now_us + self.step_us)
            self.wait_for(nxt)
            scheduler.run_until(nxt)

    def stats(self) -> dict:
        """Pacing statistics: steps paced and late, p50/p99/max lateness of the late steps [µs],
        and the real-time factor achieved (simulated over wall time up to the last step: 1.0
        when the run kept up, below 1 when it fell behind)."""
        late = sorted(self.late_us)
        wall = self._wall_last - self._wall0
        rtf = round((self._sim_last_us - self.start_sim_us) / 1e6 / wall, 4) if wall > 0 else None
        base = {"steps": self.steps, "realtime_factor": rtf}
        if not late:
            return {**base, "late_steps": 0, "p50_late_us": 0, "p99_late_us": 0, "max_late_us": 0}
        return {**base, "late_steps": len(late), "p50_late_us": late[len(late) // 2],
                "p99_late_us": late[min(len(late) - 1, int(0.99 * len(late)))], "max_late_us": late[-1]}
