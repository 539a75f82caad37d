"""``schmidt-fil validate-paper --out DIR``: rerun the validation against the paper (docs/validation.md)."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_subparser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("validate-paper",
                       help="run every scenario of the paper validation and write validation.json / validation.md")
    p.add_argument("--out", type=Path, required=True, help="output directory")
    p.add_argument("--duration-scale", type=float, default=1.0,
                   help="shorten every segment by this factor (0 < s <= 1; tests/CI: structure check only)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from host.validate_paper import validate_paper

    doc = validate_paper(args.out, args.duration_scale, progress=lambda name: print(f"  ran {name}", flush=True))
    print(f"{doc['agree']} of {doc['predictions']} predicted rows agree; "
          f"wrote {args.out / 'validation.json'} and {args.out / 'validation.md'}")
    return 0
