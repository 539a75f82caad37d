"""The two clocks a session runs on: simulated time as fast as it goes, or paced to the wall clock.

:class:`SimClock` advances a scheduler in steps (the one stepping loop of the emulator, used by
``schmidt-fil run``, ``serve`` and the host's power-on); :class:`RealtimePacer` subclasses it
and only adds the wait for the wall clock before each step, as SimPy's ``RealtimeEnvironment``
subclasses its ``Environment``. A session picks the paced clock on a real bus (SocketCAN
``vcan0``/``can0``).

The scheduler still owns simulated time; the pacer only holds the run back so that simulated
time does not get ahead of the wall clock, sleeping to absolute deadlines (FACTS.md: lateness
p50 ≈ 0.1 ms, p99 0.25–0.5 ms, with 15–45 ms VM stalls every few seconds). It never runs the
simulation faster to "catch up" silently: lateness is measured and reported, as SimPy's
real-time environment raises when it falls behind. Boards and plant never see the wall clock.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

__all__ = ["SimClock", "RealtimePacer", "clock_for", "SIM_STEP_US"]

#: Step of the simulated clock [µs]: how often a run reports progress or a session checks for
#: a stop request when nothing paces it.
SIM_STEP_US = 200_000


class SimClock:
    """Simulated time as fast as the machine runs it, in steps of ``step_us``.

    Parameters
    ----------
    step_us : int
        Step between checks of ``should_stop`` and calls of ``on_step`` [µs] (default 0.2 s).
    """

    step_us: int = SIM_STEP_US

    def __init__(self, step_us: int = SIM_STEP_US) -> None:
        self.step_us = int(step_us)

    def wait_for(self, sim_us: int) -> None:
        """Nothing to wait for in simulated time (the paced clock sleeps here)."""

    def run_until(self, scheduler, t_us: int | None, should_stop=None, on_step=None) -> bool:
        """Run ``scheduler`` to ``t_us`` (``None``: until ``should_stop()``) in steps of
        ``step_us``, each after :meth:`wait_for` its end.

        Parameters
        ----------
        scheduler : bus.scheduler.Scheduler
        t_us : int or None
            Simulated end time [µs].
        should_stop : callable() -> bool, optional
            Checked before every step.
        on_step : callable(), optional
            Called after every step (progress bars, log flushes).

        Returns
        -------
        bool
            True when ``t_us`` was reached, False when ``should_stop()`` ended it.
        """
        while True:
            if should_stop is not None and should_stop():
                return False
            if t_us is not None and scheduler.now_us >= t_us:
                return True
            nxt = scheduler.now_us + self.step_us if t_us is None else min(t_us, scheduler.now_us + self.step_us)
            self.wait_for(nxt)
            scheduler.run_until(nxt)
            if on_step is not None:
                on_step()

    def stats(self) -> dict | None:
        """Pacing statistics (none in simulated time)."""
        return None


def clock_for(interface: str, start_sim_us: int) -> SimClock:
    """The clock for a bus interface: paced on ``socketcan`` (nodes outside this process answer
    in wall-clock time), simulated otherwise."""
    return RealtimePacer(start_sim_us=start_sim_us) if interface == "socketcan" else SimClock()


@dataclass
class RealtimePacer(SimClock):
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
