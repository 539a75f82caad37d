"""``schmidt-fil fuzz --frames N [--seed S] [--json]``: random and adversarial frames at every
board in simulated time (host/fuzz.py); exit status 1 if an exception or a non-finite value
was seen."""

from __future__ import annotations

import argparse
import json
import sys


def add_subparser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("fuzz", help="send random and adversarial frames at every board (simulated time)")
    p.add_argument("--frames", type=int, default=100_000, help="frames to send (default 100000)")
    p.add_argument("--seed", type=int, default=0, help="generator seed (default 0)")
    p.add_argument("--stop-every", type=int, default=20_000,
                   help="frames between two STOP_ALL standstill measurements (default 20000)")
    p.add_argument("--json", action="store_true", help="print the figures as JSON")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from host.fuzz import run_fuzz

    if args.frames <= 0 or args.stop_every <= 0:
        raise ValueError(f"--frames and --stop-every must be > 0, got {args.frames}, {args.stop_every}")
    res = run_fuzz(args.frames, args.seed, stop_every=args.stop_every)
    if args.json:
        print(json.dumps(res.as_dict(), indent=1))
    else:
        d = res.as_dict()
        print(f"fuzz seed {res.seed}: {res.frames_sent} frames ({res.frames_via_bus} over the bus, "
              f"{res.frames_direct} injected) in {res.simulated_s:.1f} s simulated, {res.wall_s:.1f} s wall")
        print(f"exceptions {res.exceptions}; non-finite {res.non_finite}; soft-limit overshoot "
              f"RA {d['overshoot_arcsec']['ra']:.1f}\" DEC {d['overshoot_arcsec']['dec']:.1f}\"; "
              f"STOP to standstill max {res.stop_to_standstill_max_ms:.0f} ms over {res.stop_trials} "
              f"trials ({res.stop_timeouts} timeouts)")
        for m in res.exception_messages:
            print(f"  {m}", file=sys.stderr)
    return 1 if (res.exceptions or res.non_finite) else 0
