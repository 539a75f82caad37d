"""``schmidt-fil calibrate`` and ``schmidt-fil generate-record``.

``calibrate RECORD [--validate RECORD] --out DIR [--columns a=b,...] [--linear] [--axis ra]``
fits the plant model to a record, adds significant effects and writes ``report.json``,
``report.md``, PNG plots and ``calibrated_parameters.yaml`` (see :mod:`plant.calibration.report`).

``generate-record --effect KIND --out FILE.csv [--seed N] [--param k=v,...]`` writes a synthetic
record made with an undeclared effect (see :mod:`plant.calibration.generate`).
"""

from __future__ import annotations

import argparse


def add_subparser(subparsers: argparse._SubParsersAction) -> None:
    """Register ``calibrate`` and ``generate-record``."""
    p = subparsers.add_parser(
        "calibrate",
        help="fit the plant model to a measured record, find and add missing effects",
        description="Baseline least-squares fit, residual analysis, greedy effect selection with a "
        "significance rule; writes report.json, report.md, plots and a calibrated parameter file.",
    )
    p.add_argument("record", help="training record: EMPS .mat, a schmidt-fil sensor.log, or CSV (time_s, torque_nm, position_rad[, velocity_rad_s, current_a])")
    p.add_argument("--validate", metavar="RECORD", help="held-out record for validation (EMPS: DATA_EMPS_PULSES.mat)")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")
    p.add_argument("--columns", metavar="MAP", help="CSV column mapping canonical=name,... e.g. time_s=t,torque_nm=tau")
    p.add_argument("--linear", action="store_true", help="CSV position in m and force in N (linear drive)")
    p.add_argument("--axis", default="ra", help="axis: which sensor.log columns to read, and which axis of the plant parameter file receives the model (default ra)")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    p.add_argument("--gear-stiffness", type=float, metavar="K",
                   help="stiffness of the drive between the logged position and the load [N m/rad at the axis; N/m with "
                        "--linear], from the drive's design: a pre-sliding or backlash effect must then also predict better than "
                        "the gear spring alone, the report gives the backlash gap (the fitted width is the motion lost at a "
                        "reversal, gap + half the gear's wind-up) and the plant file receives the gap")
    p.add_argument("--drive-periods", metavar="P,...",
                   help="known periods of the drive [rad; m with --linear] — a motor or worm revolution, a screw lead "
                        "(EMPS: 0.0025): a position line at one of them is named even when the motion it causes is under "
                        "10 position quanta, which the record alone cannot tell from the measurement chain's structure")
    p.set_defaults(func=run)

    g = subparsers.add_parser(
        "generate-record",
        help="make a synthetic calibration record with an undeclared effect",
        description="Simulate a calibration run (velocity staircase both directions, reversals) with one "
        "effect switched on, noise and encoder quantization; write a CSV record.",
    )
    g.add_argument("--effect", default="none", help="none, delay, or an effect kind (asymmetric_friction, position_periodic, ...)")
    g.add_argument("--param", metavar="K=V,...", help="effect parameter overrides, e.g. period_rad=0.05,amplitude_nm=20")
    g.add_argument("--seed", type=int, default=0)
    g.add_argument("--duration", type=float, default=None, help="record length [s] (default: the staircase's)")
    g.add_argument("--out", required=True, metavar="FILE", help="output CSV")
    g.set_defaults(func=run_generate)


def parse_periods(text: str) -> tuple[float, ...]:
    """``--drive-periods`` → periods [rad or m]; one-line error naming the option and the bad item.

    Raises
    ------
    ValueError
        An item that is not a positive finite number.
    """
    out = []
    for item in text.split(","):
        try:
            v = float(item)
        except ValueError:
            v = float("nan")
        if not (v > 0 and v != float("inf")):
            raise ValueError(f"--drive-periods: expected comma-separated positive periods [rad, or m with --linear], "
                             f"got {item.strip()!r}")
        out.append(v)
    return tuple(out)


def run(args: argparse.Namespace) -> int:
    """Run ``calibrate``; prints a short summary; returns 0."""
    from plant.calibration.io import parse_columns
    from plant.calibration.loop import LoopConfig
    from plant.calibration.report import calibrate

    rep = calibrate(
        args.record, args.out, validate_path=args.validate, columns=parse_columns(args.columns),
        linear=args.linear, plots=not args.no_plots, axis=args.axis, gear_stiffness=args.gear_stiffness,
        config=LoopConfig(drive_periods=parse_periods(args.drive_periods)) if args.drive_periods else None,
    )
    b, f = rep["baseline"], rep["final"]
    print(f"baseline: rms {b['rms']:.4g}, relative error {b['relative_error_pct']:.3f} %")
    for e in rep["effects"]:
        gap = e.get("gap_rad", e.get("gap_m"))
        print(f"  + {e['kind']}: {e['params']} (explains {e['variance_explained_pct']:.1f} %)"
              + (f"; gap {gap:.4g} with the gear stiffness {e['gear_stiffness']:.4g}" if gap is not None else ""))
    print(f"final:    rms {f['rms']:.4g}, relative error {f['relative_error_pct']:.3f} %")
    if "validation" in rep:
        v = rep["validation"]
        pct = 100.0 * (v["rms_after"] / v["rms_before"] - 1.0)
        lib = v.get("rms_after_library_only")
        print(f"held-out: rms {v['rms_before']:.4g} -> {v['rms_after']:.4g} ({pct:+.1f} %)"
              + (f"; library effects alone (the plant file's model): {lib:.4g} ({100.0 * (lib / v['rms_before'] - 1.0):+.1f} %)"
                 if lib is not None and lib != v["rms_after"] else ""))
    if "closed_loop" in rep:
        c = rep["closed_loop"]
        print(f"closed loop force error: baseline {c['baseline_pct']:.2f} %, with effects {c['final_with_effects_pct']:.2f} %")
    for u in rep["unexplained"]:
        where = f"{u['frequency']:.4g} {u.get('unit', '')}" if u.get("frequency") is not None else (u.get("kind") or "broadband")
        print(f"  unexplained: {u['domain']} {where} ({u['share_pct']:.1f} %)")
    print(f"wrote {args.out}/report.json, report.md, {rep['model_file']}")
    return 0


def run_generate(args: argparse.Namespace) -> int:
    """Run ``generate-record``; returns 0."""
    from plant.calibration.generate import generate_record, parse_params
    from plant.calibration.io import write_csv

    rec = generate_record(args.effect, params=parse_params(args.param), seed=args.seed, duration_s=args.duration)
    path = write_csv(rec, args.out)
    print(f"wrote {path} ({len(rec)} samples, effect {args.effect})")
    return 0
