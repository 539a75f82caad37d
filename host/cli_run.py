"""``schmidt-fil run SCENARIO --out DIR``: run a scenario with a progress bar."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_subparser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help="run a scenario on the emulated network and write logs, report and plots")
    p.add_argument("scenario", type=Path, help="scenario YAML file")
    p.add_argument("--out", type=Path, required=True, help="output directory (created)")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from host.runner import run_scenario
    from host.scenario import load_scenario

    scenario = load_scenario(args.scenario)  # validated before anything runs
    console = Console(stderr=True)
    if args.quiet:
        result = run_scenario(scenario, args.out, plots=not args.no_plots)
    else:
        with Progress(
            TextColumn(f"[bold]{scenario.name}"),
            BarColumn(),
            TextColumn("{task.completed:.1f}/{task.total:.1f} s simulated"),
            TimeElapsedColumn(),
            console=console,
            transient=False,
        ) as bar:
            task = bar.add_task("run", total=scenario.duration_s)

            def progress(done_s: float, total_s: float) -> None:
                bar.update(task, completed=done_s, total=total_s)

            result = run_scenario(scenario, args.out, progress=progress, plots=not args.no_plots)
    rep = result.report
    console.print(f"simulated {rep['simulated_s']:.1f} s in {rep['wall_s']:.1f} s "
                  f"({rep['simulated_s'] / max(rep['wall_s'], 1e-9):.0f}x real time, with set-up, logs and "
                  f"candump; `schmidt-fil bench` times the network alone)")
    for s in rep["segments"]:
        if s.get("peak_error_pct") is None:
            continue
        console.print(f"  {s['name']:<22} {s['axis']:<3} {s['mode']:<9} {s['setpoint_arcsec_s']:>9.3f} ″/s  "
                      f"peak {s['peak_error_pct']:7.2f} %  rms {s['rms_error_pct']:6.2f} %  "
                      f"limit cycle {'yes' if s['limit_cycle'] else 'no'}")
    console.print(f"wrote {len(result.files)} files to {args.out}")
    return 0
