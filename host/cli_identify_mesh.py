"""``schmidt-fil identify-mesh``: identify the RA stage-1 gear-mesh amplitude on paper Fig. 6a alone."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_subparser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "identify-mesh",
        help="identify the RA stage-1 gear-mesh torque amplitude on paper Fig. 6a (open loop, 600\"/s, 15 %% "
             "peak per tick) and optionally write it into the parameter file",
    )
    p.add_argument("--params", type=Path, default=None,
                   help="parameter file to run with and write (default: the packaged plant/parameters.yaml)")
    p.add_argument("--write", action="store_true", help="write the identified amplitude and its source into --params")
    p.add_argument("--tol-nm", type=float, default=0.1, help="bisection bracket width, N m (default 0.1)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from host.identify_mesh import IDENT_KEY, TARGET_PCT, default_params_path, identify_stage1_mesh, write_amplitude

    params = args.params or default_params_path()
    if not Path(params).exists():
        raise ValueError(f"{params}: parameter file not found")
    print(f"identifying {IDENT_KEY} on paper Fig. 6a (target peak {TARGET_PCT:g} % per 5 ms tick), params {params}")
    ident = identify_stage1_mesh(Path(params), tol_nm=args.tol_nm,
                                 progress=lambda a, p: print(f"  A = {a:8.3f} N m -> peak {p:6.2f} % per tick", flush=True))
    print(f"identified: A = {ident.amplitude_nm:g} N m (peak {ident.peak_pct:g} %, bracket {ident.bracket_nm}, "
          f"{len(ident.runs)} runs)")
    if args.write:
        write_amplitude(Path(params), ident)
        print(f"written to {params}")
    return 0
