"""``schmidt-fil bench``: real-time factor of the whole network, and of the naive design.

Prints the real-time factor (simulated seconds per wall second) of the full telescope network
(two axis controllers, two EnDat readers, the focus controller and the USB-HID gateway with the
host client behind it on one emulated CAN bus, plant included) in fast mode, and — in the same process, same scenario, same simulated
span — that of the naive design where every board has its own python-can ``virtual`` Bus
(python-can copies each frame once per attached Bus). The ratio is ``rtf / rtf_naive``.

This is a benchmark, not a test: numbers depend on the machine and its load. Target (issue 2):
``rtf`` ≥ 50 on one core of the 2-core reference machine.
"""

from __future__ import annotations

import argparse
import json
import resource
import time
from pathlib import Path

DEFAULT_SCENARIO = Path(__file__).resolve().parent.parent / "scenarios" / "tracking-low-preload.yaml"


def add_subparser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bench", help="benchmark: real-time factor of the network vs the naive one-virtual-bus-per-board design")
    p.add_argument("--scenario", type=Path, default=None, help="scenario to time (default: tracking-low-preload)")
    p.add_argument("--seconds", type=float, default=20.0, help="simulated seconds per measurement (default 20)")
    p.add_argument("--repeat", type=int, default=3, help="measurements per design; the best is reported (default 3)")
    p.add_argument("--json", action="store_true", help="print JSON: rtf, rtf_naive, ratio, boards, ...")
    p.set_defaults(func=run)


def measure(scenario, seconds: float, interface: str) -> dict:
    """Build the network with ``interface`` and time ``seconds`` of simulated tracking.

    Returns a dict with ``rtf`` (simulated s per wall s), ``wall_s``, ``boards``, ``frames``.
    """
    from host.network import build_network

    sc = scenario.model_copy(update={"bus": scenario.bus.model_copy(update={"interface": interface,
                                                                         "channel": f"bench-{interface}"})})
    tel = build_network(sc)
    try:
        client = tel.client
        health = client.power_on()
        if not health.ok:
            raise RuntimeError(f"bench network failed its health check: {health.missing}")
        seg = sc.segments[0]
        client.command_axis(seg.axis if seg.axis != "both" else "ra", seg.mode, seg.direction, seg.rate_arcsec_s)
        t0 = tel.scheduler.now_us
        w0 = time.perf_counter()
        tel.scheduler.run_until(t0 + int(seconds * 1e6))
        wall = time.perf_counter() - w0
        return {"rtf": seconds / wall, "wall_s": wall, "boards": len(tel.boards),
                "frames": client.frames_received}
    finally:
        tel.close()


def plant_cost_us_per_tick(drive_model: str, ticks: int = 2000, interpreted: bool = False) -> float:
    """Wall µs per 5 ms tick of one RA plant alone (a fixed duty, the axis moving).

    ``interpreted=True`` swaps in the interpreted copy of :mod:`plant.kernel` (as with
    ``SCHMIDT_FIL_JIT=0``) for this measurement only.
    """
    from plant import axis as plant_axis
    from plant import kernel
    from plant.params import load_parameters

    ax = plant_axis.AxisPlant(load_parameters(overrides={"axes.ra.drive_model": drive_model}).ra, name="ra")
    ax.set_duties(0.3, 0.075)
    saved = plant_axis.kernel
    if interpreted:
        plant_axis.kernel = kernel.interpreted()
    try:
        t = 0
        for _ in range(200):
            t += 5_000
            ax.advance_to(t)
        w0 = time.perf_counter()
        for _ in range(ticks):
            t += 5_000
            ax.advance_to(t)
        return (time.perf_counter() - w0) / ticks * 1e6
    finally:
        plant_axis.kernel = saved


def run(args: argparse.Namespace) -> int:
    from host.scenario import load_scenario
    from plant import kernel

    scenario = load_scenario(args.scenario or DEFAULT_SCENARIO)
    best = {}
    for interface in ("sim", "virtual"):
        runs = [measure(scenario, args.seconds, interface) for _ in range(max(1, args.repeat))]
        best[interface] = max(runs, key=lambda r: r["rtf"])
    out = {
        "rtf": round(best["sim"]["rtf"], 2),
        "rtf_naive": round(best["virtual"]["rtf"], 2),
        "ratio": round(best["sim"]["rtf"] / best["virtual"]["rtf"], 2),
        "boards": best["sim"]["boards"],
        "simulated_s": args.seconds,
        "repeat": args.repeat,
        "scenario": scenario.name,
        "frames_received_by_host": best["sim"]["frames"],
        "max_rss_mib": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
        "plant_backend": kernel.BACKEND,
        "plant_us_per_tick": {m: round(min(plant_cost_us_per_tick(m) for _ in range(args.repeat)), 2)
                              for m in ("twin_train", "rigid")},
        "plant_us_per_tick_interpreted": {
            m: round(min(plant_cost_us_per_tick(m, interpreted=True) for _ in range(args.repeat)), 2)
            for m in ("twin_train", "rigid")},
        "target_rtf": 50,
    }
    if args.json:
        print(json.dumps(out))
    else:
        print(f"network ({out['boards']} boards incl. the host's USB gateway, in-process sim bus): {out['rtf']:8.1f}x real time")
        print(f"naive (one python-can virtual Bus per board):            {out['rtf_naive']:8.1f}x real time")
        print(f"ratio: {out['ratio']:.2f}   target rtf >= 50: {'met' if out['rtf'] >= 50 else 'NOT met'}   "
              f"max RSS {out['max_rss_mib']} MiB")
        pc, pi = out["plant_us_per_tick"], out["plant_us_per_tick_interpreted"]
        print(f"one axis plant alone, per 5 ms tick ({out['plant_backend']} kernel): twin_train "
              f"{pc['twin_train']} µs, rigid {pc['rigid']} µs; interpreted: twin_train "
              f"{pi['twin_train']} µs, rigid {pi['rigid']} µs")
    return 0
