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


def open_emulator_link(scenario_path: Path | None = None, sdo_timeout_s: float = 0.02) -> Link:
    """Build the scenario's network in simulated time and return a link on its bus.

    The scenario's ``segments`` are not run (nothing commands the boards but the suite); its
    plant, controller and faults are used. A scenario on ``socketcan`` is built on the
    in-process bus instead.

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

    return Link(bus, advance, lambda: sched.now_us / 1e6, sdo_timeout_s=sdo_timeout_s,
                description=f"in-process emulator, simulated time ({path.name})", close=tel.close)
