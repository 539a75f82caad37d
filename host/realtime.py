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

    def __post_init__(self) -> None:
        self._wall0 = time.monotonic()

    def wait_for(self, sim_us: int) -> None:
        """Sleep until the wall clock reaches simulated time ``sim_us``; record lateness."""
        deadline = self._wall0 + (sim_us - self.start_sim_us) / 1e6
        now = time.monotonic()
        if now < deadline:
            time.sleep(deadline - now)
        else:
            self.late_us.append(int((now - deadline) * 1e6))

    def stats(self) -> dict:
        """Lateness statistics: steps late, p50/p99/max lateness [µs]."""
        late = sorted(self.late_us)
        if not late:
            return {"late_steps": 0, "p50_late_us": 0, "p99_late_us": 0, "max_late_us": 0}
        return {"late_steps": len(late), "p50_late_us": late[len(late) // 2],
                "p99_late_us": late[min(len(late) - 1, int(0.99 * len(late)))], "max_late_us": late[-1]}
