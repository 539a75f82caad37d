"""``schmidt-fil validate SCENARIO...``: check scenario files without running them."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_subparser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("validate", help="validate scenario files (schema and plant parameter overrides) without running")
    p.add_argument("scenarios", type=Path, nargs="+")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from host.scenario import load_scenario, resolve_parameters

    for path in args.scenarios:
        sc = load_scenario(path)
        resolve_parameters(sc)  # parameter file and overrides must resolve too
        print(f"{path}: ok ({len(sc.segments)} segments, {sc.duration_s:g} s)")
    return 0
