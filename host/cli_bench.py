"""``schmidt-fil bench``: real-time factor of a network, and of the naive design, with bus load.

Prints the real-time factor (simulated seconds per wall second) of a telescope network (its
boards and the host on one emulated CAN bus, plant included) in fast mode, and — in the same
process, same scenario, same simulated span — that of the naive design where every node has its
own python-can ``virtual`` Bus (python-can copies each frame once per attached Bus), their ratio,
the bus load the emulated bus measured over the timed span (busy time incl. stuff bits and
intermission / elapsed time) and the process's peak memory.

``--network NAME`` chooses the network by name (:func:`networks`: ``boards.registry.NETWORKS``).
A network is only a list of board instance names handed to :func:`measure`; nothing else here
depends on which boards run.

This is a benchmark, not a test: numbers depend on the machine and its load. Targets (issue 12,
2-core reference machine): ``basic`` ≥ 80× real time; ``full`` ≥ 50× and ≥ 10× the naive design.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import time
from pathlib import Path

DEFAULT_SCENARIO = Path(__file__).resolve().parent.parent / "scenarios" / "tracking-low-preload.yaml"

#: Real-time factor targets per network (issue 12); a network without an entry has none.
TARGET_RTF = {"basic": 80, "full": 50}
#: Target of rtf / rtf_naive per network (issue 12).
TARGET_RATIO = {"full": 10}


def interpreter() -> dict:
    """The Python that runs the benchmark: ``version``, ``executable`` and ``libpython_shared``.

    ``libpython_shared`` is True when the interpreter runs from a shared ``libpython*.so``
    (``/proc/self/maps``; None where that file does not exist). Two CPythons of the same version
    run this emulator at different speeds: on the 2-core VMs, Debian's ``/usr/bin/python3.11``
    (built with PGO and LTO, libpython linked into the executable) ran ``full`` 1.18× faster on
    average than pyenv's default build (no PGO, shared libpython), first on ``PATH`` there
    (docs/performance.md, "The interpreter"). A figure is comparable with another only for the
    same interpreter, so the benchmark prints which one ran.
    """
    import platform
    import sys

    shared = None
    try:
        with open("/proc/self/maps", encoding="ascii", errors="replace") as f:
            shared = any("/libpython" in line for line in f)
    except OSError:
        pass
    return {"version": platform.python_version(), "implementation": platform.python_implementation(),
            "executable": os.path.realpath(sys.executable), "libpython_shared": shared}


def networks() -> dict[str, tuple[str, ...]]:
    """Network name -> board instance names: ``boards.registry.NETWORKS`` (``basic``, ``lab``,
    ``full``)."""
    from boards.registry import NETWORKS

    return {name: tuple(boards) for name, boards in NETWORKS.items()}


def add_subparser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bench", help="benchmark: real-time factor of the network vs the naive one-virtual-bus-per-board design")
    p.add_argument("--network", default="basic",
                   help=f"network to time, by name (default basic; known: {', '.join(networks())})")
    p.add_argument("--scenario", type=Path, default=None, help="scenario to time (default: tracking-low-preload)")
    p.add_argument("--seconds", type=float, default=20.0, help="simulated seconds per measurement (default 20)")
    p.add_argument("--repeat", type=int, default=3, help="measurements per design, the two designs in alternation; the best of each is reported, and every run (default 3)")
    p.add_argument("--json", action="store_true",
                   help="print JSON: rtf, rtf_naive, ratio, boards, bus_load_pct, peak_memory, ...")
    p.set_defaults(func=run)


def _with_boards(scenario, boards):
    """``scenario`` running network ``boards``: a name of :func:`networks` or a list of board
    instance names of the registry (None: the scenario's own)."""
    if boards is None:
        return scenario
    return scenario.model_copy(update={"network": boards if isinstance(boards, str) else list(boards)})


def measure(scenario, seconds: float, interface: str, boards=None) -> dict:
    """Build the network with ``interface`` and time ``seconds`` of simulated tracking.

    Parameters
    ----------
    scenario : host.scenario.Scenario
        What to run (its first segment's command is sent after the health check).
    seconds : float
        Simulated span timed, s.
    interface : {"sim", "virtual"}
        The emulated bus, or the naive one-``virtual``-Bus-per-node design.
    boards : str or sequence of str, optional
        The network: a name of :func:`networks` or a list of board instance names (default:
        the scenario's own).

    Returns
    -------
    dict
        ``rtf`` (simulated s per wall s), ``rtf_cpu`` (simulated s per CPU second of this process:
        what other processes on a shared machine change least), ``wall_s``, ``boards`` (count),
        ``frames`` (received by
        the host), and on the emulated bus ``bus_frames`` and ``bus_load_pct`` over the timed span
        (``None`` on ``virtual``, which has no bus timing).
    """
    from host.network import build_network

    sc = _with_boards(scenario, boards)
    sc = sc.model_copy(update={"bus": sc.bus.model_copy(update={"interface": interface,
                                                               "channel": f"bench-{interface}"})})
    tel = build_network(sc)
    try:
        client = tel.client
        health = client.power_on()
        if not health.ok:
            raise RuntimeError(f"bench network failed its health check: {health.missing}")
        seg = sc.segments[0]
        client.command_axis(seg.axis if seg.axis != "both" else "ra", seg.mode, seg.direction, seg.rate_arcsec_s)
        net = tel.network
        t0 = tel.scheduler.now_us
        busy0, frames0 = (net.busy_us, net.frames) if net is not None else (0, 0)
        c0, w0 = time.process_time(), time.perf_counter()
        tel.scheduler.run_until(t0 + int(seconds * 1e6))
        wall = time.perf_counter() - w0
        cpu = time.process_time() - c0
        span_us = tel.scheduler.now_us - t0
        out = {"rtf": seconds / wall, "rtf_cpu": seconds / cpu if cpu > 0 else None,
               "wall_s": wall, "boards": len(tel.boards),
               "frames": client.frames_received, "bus_frames": None, "bus_load_pct": None}
        if net is not None:
            out["bus_frames"] = net.frames - frames0
            out["bus_load_pct"] = 100.0 * (net.busy_us - busy0) / span_us
        return out
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


def bench(scenario, network: str, seconds: float, repeat: int) -> dict:
    """Measure network ``network`` (a key of :func:`networks`) both ways; the JSON of ``--json``.

    Raises
    ------
    ValueError
        For an unknown network name (the message lists the known ones).
    """
    from bus._native import NATIVE_MODULES, native_modules
    from plant import kernel

    nets = networks()
    if network not in nets:
        raise ValueError(f"unknown network {network!r}; known: {', '.join(nets)}")
    boards = nets[network]
    # The two designs are timed in alternation (network, naive, network, naive, ...): the VM's
    # speed changes within a minute (docs/performance.md), and a ratio of two runs made seconds
    # apart is what that change moves least. ``ratio`` is best over best, as printed;
    # ``ratio_pairs`` the ratio within each adjacent pair.
    runs: dict[str, list[dict]] = {"sim": [], "virtual": []}
    for _ in range(max(1, repeat)):
        for interface in ("sim", "virtual"):
            runs[interface].append(measure(scenario, seconds, interface, network))
    best = {k: max(v, key=lambda r: r["rtf"]) for k, v in runs.items()}
    pairs = [a["rtf"] / b["rtf"] for a, b in zip(runs["sim"], runs["virtual"])]
    sim = best["sim"]
    return {
        "network": network,
        "rtf": round(sim["rtf"], 2),
        "rtf_naive": round(best["virtual"]["rtf"], 2),
        "ratio": round(sim["rtf"] / best["virtual"]["rtf"], 2),
        "rtf_runs": [round(r["rtf"], 2) for r in runs["sim"]],
        "rtf_naive_runs": [round(r["rtf"], 2) for r in runs["virtual"]],
        "ratio_pairs": [round(x, 2) for x in pairs],
        "rtf_cpu": round(sim["rtf_cpu"], 2) if sim["rtf_cpu"] else None,
        "rtf_naive_cpu": round(best["virtual"]["rtf_cpu"], 2) if best["virtual"]["rtf_cpu"] else None,
        "load_average_1min": round(os.getloadavg()[0], 2),
        "boards": sim["boards"],
        "board_names": list(boards),
        "bus_load_pct": round(sim["bus_load_pct"], 2),
        "bus_frames_per_s": round(sim["bus_frames"] / seconds, 1),
        "peak_memory": {"max_rss_mib": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)},
        "simulated_s": seconds,
        "repeat": repeat,
        "scenario": scenario.name,
        "frames_received_by_host": sim["frames"],
        "plant_backend": kernel.BACKEND,
        "plant_us_per_tick": {m: round(min(plant_cost_us_per_tick(m) for _ in range(repeat)), 2)
                              for m in ("twin_train", "rigid")},
        "plant_us_per_tick_interpreted": {
            m: round(min(plant_cost_us_per_tick(m, interpreted=True) for _ in range(repeat)), 2)
            for m in ("twin_train", "rigid")},
        "target_rtf": TARGET_RTF.get(network),
        "target_ratio": TARGET_RATIO.get(network),
        # the hot path compiled by mypyc at install (docs/performance.md "Compiled hot path"):
        # which of bus._native.NATIVE_MODULES ran compiled (SCHMIDT_FIL_NATIVE=0: none)
        "native_modules": len(native_modules()),
        "native_modules_listed": len(NATIVE_MODULES),
        "python": interpreter(),
    }


def run(args: argparse.Namespace) -> int:
    from host.scenario import load_scenario

    if args.network not in networks():      # before anything runs
        raise ValueError(f"unknown network {args.network!r}; known: {', '.join(networks())}")
    scenario = load_scenario(args.scenario or DEFAULT_SCENARIO)
    out = bench(scenario, args.network, args.seconds, args.repeat)
    if args.json:
        print(json.dumps(out))
        return 0

    def verdict(value, target):
        return "" if target is None else f"  (target >= {target}: {'met' if value >= target else 'NOT met'})"

    print(f"network {out['network']!r} ({out['boards']} boards + host, in-process sim bus): "
          f"{out['rtf']:8.1f}x real time{verdict(out['rtf'], out['target_rtf'])}")
    print(f"naive (one python-can virtual Bus per node):            {out['rtf_naive']:8.1f}x real time")
    print(f"per CPU second of this process: network {out['rtf_cpu']}x, naive {out['rtf_naive_cpu']}x "
          f"(machine load average {out['load_average_1min']}: wall figures drop when other processes run)")
    if len(out["rtf_runs"]) > 1:
        print("runs, in alternation (network / naive / ratio): "
              + ", ".join(f"{a:.1f} / {b:.1f} / {c:.1f}"
                          for a, b, c in zip(out["rtf_runs"], out["rtf_naive_runs"], out["ratio_pairs"]))
              + " (the best of each is above; the spread is the machine's)")
    print(f"ratio: {out['ratio']:.2f}{verdict(out['ratio'], out['target_ratio'])}   bus load "
          f"{out['bus_load_pct']:.1f} % ({out['bus_frames_per_s']:.0f} frames/s)   "
          f"peak memory (max RSS) {out['peak_memory']['max_rss_mib']} MiB")
    print(f"compiled hot path (mypyc): {out['native_modules']} of {out['native_modules_listed']} modules"
          + ("" if out["native_modules"] else
             " (pure Python: SCHMIDT_FIL_NATIVE=0, or installed without compiling; docs/performance.md)"))
    py = out["python"]
    print(f"python {py['version']} ({py['executable']}; libpython "
          + {True: "shared: slower than a static PGO build, docs/performance.md \"The interpreter\")",
             False: "linked in)", None: "unknown)"}[py["libpython_shared"]])
    pc, pi = out["plant_us_per_tick"], out["plant_us_per_tick_interpreted"]
    print(f"one axis plant alone, per 5 ms tick ({out['plant_backend']} kernel): twin_train "
          f"{pc['twin_train']} µs, rigid {pc['rigid']} µs; interpreted: twin_train "
          f"{pi['twin_train']} µs, rigid {pi['rigid']} µs")
    return 0
