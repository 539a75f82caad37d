"""The in-process emulator as the device under test (``schmidt-fil conform`` without --interface).

This is the only module of the suite that imports the emulator (``host.network``): it builds
the network of a scenario on the in-process ``sim`` bus with a passive host node (the
``serve`` monitor), opens a second python-can bus on its channel for the conformance host and
lets waiting advance the emulator's clock (docs/serve.md, "In the same Python process"). The
checks never see the emulator: only the bus.
"""

from __future__ import annotations

import math
from pathlib import Path

import can

from host.conformance.link import Link

__all__ = ["DEFAULT_SCENARIO", "open_emulator_link"]

DEFAULT_SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "tracking-low-preload.yaml"


#: Burst pattern of a slow emulator (``rate``): the emulator's advance per wall step is
#: ``rate × step × X``, X drawn from these with equal weight (mean 1): it stalls, crawls and
#: catches up, as the paced emulator behind ``serve`` does in a software-emulated guest.
BURSTS = (0.0, 0.0, 0.0, 0.5, 1.0, 1.5, 4.0)
#: A slow emulator's host is busy too: when a check stamps the link's time (``Link.now``) the
#: devices have, with this probability, run on for up to ``HOST_BUSY_MAX_S`` of wall time since
#: the host last read (assumed, from the CI guest's run of a056670: its conform host stamped a
#: command ≈ 60 ms of device time behind the bus, after scanning ~10⁵ received frames in TCG).
HOST_BUSY_PROBABILITY = 0.5
HOST_BUSY_MAX_S = 0.5


def open_emulator_link(scenario_path: Path | None = None, sdo_timeout_s: float = 0.02, *,
                       rate: float | None = None, seed: int = 1, device_clock=None,
                       min_rate: float = 0.05, host_stall: tuple[int, float] | None = None) -> Link:
    """Build the scenario's network in simulated time and return a link on its bus.

    The scenario's ``segments`` are not run (nothing commands the boards but the suite); its
    plant, controller and faults are used. A scenario on ``socketcan`` is built on the
    in-process bus instead.

    With ``rate`` (a test aid for the device clock, docs/conformance.md) the link runs on a
    *virtual wall clock* in 1 ms steps and the emulator follows it slower and in bursts — on
    average ``rate`` simulated seconds per wall second, never ahead of the wall clock, seeded
    (``seed``) so a run is repeatable. The link then waits as on a real bus: on
    ``device_clock`` (counted from the frames) if given, else on that wall clock; the suite
    never reads the emulator's clock.

    ``host_stall = (cob_id, seconds)`` (test aid, with ``rate``): at the host's first stamp
    (:meth:`Link.now`) after its first frame on ``cob_id``, the emulator runs ``seconds`` while
    the host neither reads nor beats — a host process descheduled, as in the QEMU guest
    (docs/conformance.md, "The host's own heartbeat").

    Raises
    ------
    ScenarioError
        The scenario does not load (one line naming the file and key).
    """
    from host.monitor import BusMonitor
    from host.network import build_network
    from host.scenario import load_scenario

    path = Path(scenario_path or DEFAULT_SCENARIO)
    sc = load_scenario(path)
    if sc.bus.interface != "sim":
        sc = sc.model_copy(update={"bus": sc.bus.model_copy(update={"interface": "sim"})})
    tel = build_network(sc, host_cls=BusMonitor)
    bus = can.Bus(interface="schmidt-sim", channel=tel.network.channel)
    sched = tel.scheduler

    def advance(until_s: float) -> None:
        # at least 1 µs: a float deadline a hair past now must not stall the caller's loop
        sched.run_until(max(sched.now_us + 1, int(math.ceil(until_s * 1e6 - 1e-3))))

    if rate is None:
        return Link(bus, advance, lambda: sched.now_us / 1e6, sdo_timeout_s=sdo_timeout_s,
                    description=f"in-process emulator, simulated time ({path.name})", close=tel.close)

    import random
    rng = random.Random(seed)
    wall = [sched.now_us / 1e6]

    def advance_slowly(until_wall_s: float) -> None:
        dt = max(until_wall_s - wall[0], 1e-6)
        wall[0] += dt
        target = min(wall[0], sched.now_us / 1e6 + rate * dt * rng.choice(BURSTS))
        sched.run_until(max(sched.now_us, int(target * 1e6)))

    which = "the devices' clock" if device_clock is not None else "the wall clock"
    link = Link(bus, advance_slowly, lambda: wall[0], step_s=1e-3, sdo_timeout_s=sdo_timeout_s,
                device_clock=device_clock, min_rate=min_rate, close=tel.close,
                description=f"in-process emulator at {rate:g}× a virtual wall clock, bursty "
                            f"(seed {seed}); waits on {which} ({path.name})")
    link.wall_kind = "virtual wall"
    # the host computes between its reads (the checks scan every frame received so far): at
    # some of its stamps the devices have run on and frames wait unread in its receive queue
    stall = [host_stall]

    def host_busy() -> None:
        if stall[0] is not None and any(f.cob_id == stall[0][0] for f in link.sent):
            seconds = stall[0][1]
            stall[0] = None
            wall[0] += seconds
            sched.run_until(sched.now_us + int(seconds * 1e6))
        if rng.random() < HOST_BUSY_PROBABILITY:
            advance_slowly(wall[0] + rng.uniform(0.0, HOST_BUSY_MAX_S))

    link.host_busy = host_busy
    return link
