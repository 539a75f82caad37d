"""``schmidt-fil conform``: the protocol conformance suite against any python-can bus.

Runs the pytest-based suite of :mod:`host.conformance` (docs/conformance.md): against the
in-process emulator in simulated time (default), ``schmidt-fil serve`` on vcan0, or real
boards (``--interface socketcan --channel can0 --nodes 1,3,5``). Exit status 0 when every
asserted check passed, 1 otherwise; 2 for a usage error.
"""

from __future__ import annotations

import argparse
from pathlib import Path

#: Check modules in run order (timing before the checks that reset or move nodes).
CHECK_MODULES = ("check_presence.py", "check_timing.py", "check_nmt.py", "check_malformed.py",
                 "check_emcy.py", "check_axis.py", "check_focus.py")


def add_subparser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("conform", help="protocol conformance suite (CANopen, DBC, EDS) against the emulator or real boards",
                       description=__doc__.split("\n\n")[1])
    p.add_argument("--interface", default=None,
                   help="python-can interface (socketcan, virtual, ...); default: the in-process emulator")
    p.add_argument("--channel", default=None, help="python-can channel, e.g. vcan0, can0")
    p.add_argument("--bitrate", type=int, default=None, help="bitrate for interfaces that set it")
    p.add_argument("--scenario", type=Path, default=None,
                   help="scenario of the in-process emulator (default scenarios/tracking-low-preload.yaml)")
    p.add_argument("--nodes", default=None, help="node ids to test, e.g. 1,3,5 (default: every node heard)")
    motion = p.add_mutually_exclusive_group()
    motion.add_argument("--allow-motion", dest="allow_motion", action="store_const", const="yes",
                        help="run the checks that move an axis or the focus (default in-process)")
    motion.add_argument("--no-motion", dest="allow_motion", action="store_const", const="no",
                        help="skip them (default on a real bus)")
    p.add_argument("--timing", choices=("assert", "report"), default="assert",
                   help="assert the timing checks (default) or only report them")
    p.add_argument("--clock", choices=("device", "wall"), default="device",
                   help="on a real bus, wait on the devices' clock, counted from their periodic frames "
                        "(default: a board or an emulator slower than real time gets its documented "
                        "windows in its own time), or on the wall clock")
    p.add_argument("--min-rate", type=float, default=0.05, metavar="R",
                   help="device clock: a wait of dt seconds gives up after dt / R wall seconds (default 0.05)")
    p.add_argument("--reaction-slack", type=float, default=0.0, metavar="S",
                   help="seconds added to every reaction timeout on a real bus (for --clock wall)")
    p.add_argument("--capture", type=float, default=5.5, help="seconds of traffic for the period checks")
    p.add_argument("-k", dest="keyword", default=None, help="pytest -k expression selecting checks")
    p.add_argument("--out", type=Path, default=None, help="write conformance.json and conformance.md here")
    p.add_argument("--pytest-arg", action="append", default=[], metavar="ARG",
                   help="extra argument passed to pytest (repeatable), e.g. --pytest-arg=-x")
    p.set_defaults(func=run)


def pytest_args(args: argparse.Namespace) -> list[str]:
    """The pytest command line of ``args`` (used by :func:`run`, shown with --debug)."""
    here = Path(__file__).resolve().parent / "conformance"
    argv = [str(here / m) for m in CHECK_MODULES]
    argv += ["-o", "python_files=check_*.py", "-p", "no:cacheprovider", "--rootdir", str(here),
             "-q", "--cf-timing", args.timing, "--cf-capture", str(args.capture),
             "--cf-reaction-slack", str(args.reaction_slack), "--cf-clock", args.clock,
             "--cf-min-rate", str(args.min_rate)]
    for opt, val in (("--cf-interface", args.interface), ("--cf-channel", args.channel),
                     ("--cf-bitrate", args.bitrate), ("--cf-scenario", args.scenario),
                     ("--cf-nodes", args.nodes), ("--cf-allow-motion", args.allow_motion),
                     ("--cf-out", args.out)):
        if val is not None:
            argv += [opt, str(val)]
    if args.keyword:
        argv += ["-k", args.keyword]
    return argv + list(args.pytest_arg)


def run(args: argparse.Namespace) -> int:
    import pytest

    if args.interface and not args.channel:
        raise ValueError("--interface needs --channel (e.g. --interface socketcan --channel vcan0)")
    if args.scenario is not None and not args.scenario.is_file():
        raise ValueError(f"{args.scenario}: no such scenario file")
    code = int(pytest.main(pytest_args(args)))
    if args.out is not None:
        print(f"conformance report: {args.out / 'conformance.md'}")
    # pytest: 0 all passed, 1 failures, 5 nothing selected; usage errors 4 -> 2
    return {0: 0, 1: 1, 4: 2, 5: 1}.get(code, 1)
