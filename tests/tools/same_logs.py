"""Check that a change leaves every scenario's logs byte-identical (a tool, not a test: minutes).

Runs every scenario under ``scenarios/`` that uses the emulated (``sim``) bus, plus two short
fault scenarios defined here (every CAN-level fault kind, resets, malformed frames, RS232 on), into
``--out DIR`` (no plots). With ``--against REF`` it then compares DIR with an earlier output
directory REF file by file and exits 1 on any difference. The only fields allowed to differ are
the wall-clock ones (``wall_s`` in report.json, the "Simulated ... wall" line of report.md).

Typical use for a speed change (the behaviour must not change)::

    git stash; python tests/tools/same_logs.py --out /tmp/before; git stash pop
    python tests/tools/same_logs.py --out /tmp/after --against /tmp/before
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

#: Fault scenarios exercising the paths the scenarios/ files do not (fault confinement, loss,
#: babbling, bus-off, host loss, resets, malformed frames, EnDat CRC errors, RS232 telemetry).
FAULT_SCENARIOS = {
    "faults-can": """
name: faults-can
seed: 7
rs232: {enabled: true}
faults:
  - {at_s: 0.5, kind: can_error, board: ra-axis, probability: 0.3, duration_s: 1.0}
  - {at_s: 1.0, kind: frame_loss, board: dec-axis, probability: 0.5, duration_s: 1.0}
  - {at_s: 1.5, kind: can_error, ids: [0x183, 0x184], count: 20}
  - {at_s: 2.0, kind: babbling_node, arbitration_id: 0x005, duration_s: 0.2}
  - {at_s: 2.5, kind: bus_off, board: dec-reader, auto_recover: true}
  - {at_s: 3.0, kind: bus_off, board: focus}
  - {at_s: 3.5, kind: host_loss, duration_s: 0.5}
  - {at_s: 4.0, kind: frame_loss, probability: 0.1, duration_s: 0.5}
segments:
  - {name: slew, axis: both, mode: slew, direction: 1, duration_s: 2.5, settle_s: 1}
  - {name: track, axis: ra, mode: track, direction: 1, duration_s: 3, settle_s: 1, focus_halfsteps: 40}
""",
    "faults-boards": """
name: faults-boards
seed: 3
faults:
  - {at_s: 0.3, kind: focus_stall, board: focus, halfsteps: 7}
  - {at_s: 0.6, kind: endat_bit_flip, board: ra-reader, bit: 7}
  - {at_s: 0.8, kind: malformed_frame, board: ra-axis}
  - {at_s: 1.0, kind: board_reset, board: dec-axis}
  - {at_s: 1.5, kind: reader_loss, board: dec-reader}
  - {at_s: 2.5, kind: remove_board, board: focus}
segments:
  - {name: set, axis: both, mode: set, direction: 1, duration_s: 2, settle_s: 1, focus_halfsteps: 60}
  - {name: guide, axis: both, mode: guide, direction: -1, duration_s: 2, settle_s: 1}
""",
}

_WALL_MD = re.compile(r"^Simulated .* wall .*$", re.M)


def scenario_files() -> list[Path]:
    """scenarios/**/*.yaml on the sim bus (the socketcan ones need a kernel vcan0)."""
    import yaml

    out = []
    for f in sorted((ROOT / "scenarios").rglob("*.yaml")):
        bus = (yaml.safe_load(f.read_text(encoding="utf-8")) or {}).get("bus") or {}
        if bus.get("interface", "sim") == "sim":
            out.append(f)
    return out


def run_all(out: Path, only: list[str] | None = None) -> list[str]:
    from host.runner import run_scenario
    from host.scenario import load_scenario

    names = []
    with tempfile.TemporaryDirectory() as tmp:
        files = scenario_files()
        for name, text in FAULT_SCENARIOS.items():
            p = Path(tmp) / f"{name}.yaml"
            p.write_text(text, encoding="utf-8")
            files.append(p)
        for f in files:
            if only and f.stem not in only:
                continue
            print(f"running {f.stem} ...", flush=True)
            run_scenario(load_scenario(f), out / f.stem, plots=False)
            names.append(f.stem)
    return names


def _normalise(path: Path) -> bytes:
    data = path.read_bytes()
    if path.name == "report.json":
        rep = json.loads(data)
        rep.pop("wall_s", None)
        return json.dumps(rep, sort_keys=True).encode()
    if path.name == "report.md":
        return _WALL_MD.sub("", data.decode("utf-8")).encode()
    return data


def compare(out: Path, ref: Path) -> list[str]:
    """Differences between two output trees (missing files, differing bytes)."""
    diffs = []
    a = {p.relative_to(out) for p in out.rglob("*") if p.is_file()}
    b = {p.relative_to(ref) for p in ref.rglob("*") if p.is_file()}
    for rel in sorted(a ^ b):
        diffs.append(f"only in {'new' if rel in a else 'reference'}: {rel}")
    for rel in sorted(a & b):
        if _normalise(out / rel) != _normalise(ref / rel):
            diffs.append(f"differs: {rel}")
    return diffs


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True, help="output directory (one folder per scenario)")
    ap.add_argument("--against", type=Path, help="reference output directory to compare with")
    ap.add_argument("--only", nargs="*", help="run only these scenario names")
    args = ap.parse_args(argv)
    run_all(args.out, args.only)
    if args.against is None:
        return 0
    diffs = compare(args.out, args.against)
    for d in diffs:
        print(d)
    print("identical" if not diffs else f"{len(diffs)} difference(s)")
    return 1 if diffs else 0


if __name__ == "__main__":
    sys.exit(main())
