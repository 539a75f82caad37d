"""``schmidt-fil serve [SCENARIO] --out DIR [--channel vcan0] [--duration S]``: the five emulated
boards and the plant on a SocketCAN bus, in real time, for a host program outside the emulator.

Our host node only listens (``host.monitor.BusMonitor``) and logs; the external program sends
the health check (SDO), NMT start and commands. Runs until ``--duration`` seconds have passed or SIGINT/SIGTERM; either
way the logs are flushed and ``report.json``/``report.md`` written before it exits (status 0).
A second SIGINT interrupts at once (the logs are still closed).
"""

from __future__ import annotations

import argparse
import signal
import sys
from pathlib import Path


def add_subparser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("serve", help="serve the emulated boards and plant on SocketCAN (vcan0/can0) to your own host "
                                     "program; log what it sends")
    p.add_argument("scenario", type=Path, nargs="?", default=None,
                   help="scenario YAML for plant/bus/controller/log/rs232/faults; its segments are not run "
                        "(default scenarios/tracking-low-preload.yaml: RA and DEC at low preload)")
    p.add_argument("--out", type=Path, required=True, help="output directory for logs and report (created)")
    p.add_argument("--channel", default=None,
                   help="SocketCAN interface (default: the scenario's bus.channel if it is socketcan, else vcan0)")
    p.add_argument("--duration", type=float, default=None, metavar="S",
                   help="stop after S seconds (default: run until Ctrl-C or SIGTERM)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from host.scenario import load_scenario
    from host.serve import DEFAULT_SCENARIO, ServeSession, serve_scenario, served_interface

    if args.duration is not None and not args.duration > 0:
        raise ValueError(f"--duration must be > 0 seconds, got {args.duration}")
    path = args.scenario if args.scenario is not None else DEFAULT_SCENARIO
    scenario = serve_scenario(load_scenario(path), args.channel)  # validated before anything opens
    session = ServeSession(scenario, args.out)   # SocketCanUnavailable: one line (host.cli)

    stop = {"signal": None}

    def on_signal(signum, frame) -> None:
        stop["signal"] = signal.Signals(signum).name
        signal.signal(signum, previous[signum])   # a second one acts as usual

    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    say = lambda s="": print(s, flush=True)  # noqa: E731 - stdout, unbuffered: others wait for these lines
    try:
        chan = scenario.bus.channel
        say(f"schmidt-fil serve: scenario {path} ({scenario.name}; {len(scenario.segments)} segment(s) not run), "
            f"plant preload {session.tel.params.axes['ra'].friction.preload}, "
            f"{len(scenario.faults)} fault(s) scheduled")
        say(f"channel {chan} (socketcan), CAN 2.0A 11-bit ids, CANopen (boards boot PRE-OPERATIONAL: send NMT start); our host node 0x10 only listens")
        for b in served_interface(scenario.network):
            sends = " ".join(f"{c:03X}" for c, _ in b["sends"])
            listens = " ".join(f"{c:03X}" for c, _ in b["listens"])
            say(f"  node {b['node']} {b['board']:<10} sends {sends:<24} listens {listens}")
        say(f"logs -> {args.out}; frame layouts: docs/protocol.md, bus/schmidt.dbc")
        until = f"for {args.duration:g} s" if args.duration is not None else "until Ctrl-C"
        say(f"serving on {chan} {until}")
        session.run(args.duration, should_stop=lambda: stop["signal"] is not None)
    finally:
        for s, h in previous.items():
            signal.signal(s, h)
        if stop["signal"] is not None:
            session.stopped_by = stop["signal"]
        rep = session.close()            # flushes and closes every log, even after an error
    _summary(rep, session, say)
    return 0


def _summary(rep: dict, session, say) -> None:
    cmds = ", ".join(f"{k} x{v}" for k, v in rep["external_commands"].items()) or "none"
    say(f"served {rep['simulated_s']:.1f} s ({rep['wall_s']:.1f} s wall), stopped by {rep['stopped_by']}")
    say(f"  frames seen {rep['frames_seen_total']}; external commands: {cmds}")
    bad = {n: b["malformed_frames"] for n, b in rep["boards"].items() if b["malformed_frames"]}
    say(f"  malformed frames: boards {bad or 'none'}, host-side {rep['monitor']['malformed_frames']}; "
        f"errors {rep['errors_total']} (errors.log)")
    rt = rep["realtime"]
    if rt:
        say(f"  pacing: {rt['late_steps']}/{rt['steps']} steps late, max {rt['max_late_us'] / 1000:.1f} ms; "
            f"real-time factor {rt['realtime_factor']}")
    say(f"wrote {len(session.files())} files to {session.out_dir}")


if __name__ == "__main__":  # pragma: no cover
    from host.cli import main

    sys.exit(main(["serve", *sys.argv[1:]]))
