"""``schmidt-fil benchmark-calibration``: the calibration loop on records it has never seen.

``benchmark-calibration --out DIR [--seeds 0-59 | --ci] [--generator independent|blind] [--long N]``
generates the records of an independent generator (:mod:`plant.calibration.bench_records`, or with
``--generator blind`` :mod:`plant.calibration.blind_records`, written without reading the loop;
both import nothing from ``plant``), runs ``calibrate`` on each in a child process and writes ``benchmark.json`` and
``benchmark.md`` (confusion matrix, exact-set accuracy, false positives, per kind how often a named
kind is hidden and a hidden kind named, what the records' true motion allows, key-parameter errors,
time and peak memory per record; :mod:`host.calibration_benchmark`). The default seed list is
fixed, so the figures are reproducible.
"""

from __future__ import annotations

import argparse


def parse_seeds(text: str) -> list[int]:
    """``"0-9,12,20-22"`` -> ``[0, …, 9, 12, 20, 21, 22]``.

    Raises
    ------
    ValueError
        An item that is not an integer or a range ``a-b`` with a ≤ b.
    """
    out: list[int] = []
    for item in text.split(","):
        item = item.strip()
        if not item:
            continue
        try:
            if "-" in item:
                a, b = (int(x) for x in item.split("-", 1))
                if b < a:
                    raise ValueError
                out += list(range(a, b + 1))
            else:
                out.append(int(item))
        except ValueError:
            raise ValueError(f"--seeds item {item!r}: expected an integer or a range a-b (a <= b)") from None
    if not out:
        raise ValueError("--seeds: no seed given")
    return out


def add_subparser(subparsers: argparse._SubParsersAction) -> None:
    """Register ``benchmark-calibration``."""
    p = subparsers.add_parser(
        "benchmark-calibration",
        help="score the calibration loop on records from an independent generator",
        description="Generate records with hidden effects (library kinds, pairs, clean, out-of-library), calibrate "
        "each, write benchmark.json and benchmark.md.",
    )
    p.add_argument("--out", required=True, metavar="DIR", help="output directory (records/, runs/, benchmark.json, benchmark.md)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--seeds", metavar="LIST", help="seeds, e.g. 0-59 or 0,5,30 (default: the fixed list 0-59)")
    g.add_argument("--ci", action="store_true", help="the small fixed subset CI runs")
    p.add_argument("--generator", default="independent", metavar="NAME",
                   help="record generator: 'independent' (default; the fixed seeds of the figures in README) or 'blind' "
                        "(written without reading the calibration code; docs/calibration.md, 'Session 24')")
    p.add_argument("--long", type=int, metavar="N", default=None,
                   help="also calibrate one long record of N samples (e.g. 1000000) and report its time and peak memory")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the benchmark; print the summary; returns 0."""
    from host.calibration_benchmark import CI_SEEDS, DEFAULT_SEEDS, run_benchmark

    seeds = parse_seeds(args.seeds) if args.seeds else (list(CI_SEEDS) if args.ci else list(DEFAULT_SEEDS))
    res = run_benchmark(args.out, seeds, long_samples=args.long, generator_name=args.generator)
    s = res["summary"]
    print(f"exact set {s['n_exact']}/{s['n_records']}; clean false positives {len(s['clean']['false_positive_seeds'])}/{s['clean']['n']}; "
          f"out-of-library ok {s['out_of_library']['ok']}/{s['out_of_library']['n']}")
    print("when named, hidden (per kind): " + "; ".join(f"{k} {v['named_and_hidden']}/{v['named']}"
                                                      for k, v in s["per_kind"].items() if v["named"]))
    if s.get("limits"):
        lim = s["limits"]
        print(f"what the records allow (true motion): nameable at all {lim['nameable']}/{s['n_records']}, at the rank test's level "
              f"{lim['nameable_at_rule_level']}/{s['n_records']}; wrong by class: "
              + ("; ".join(f"{k} {v['n']}" for k, v in lim["classes"].items()) or "none"))
    print(f"wrote {args.out}/benchmark.json and benchmark.md")
    return 0
