"""Write the EDS files (CiA 306) of :mod:`bus.eds.objects` — the shipped files are its output.

Usage::

    python -m bus.eds.generate          # rewrite bus/eds/*.eds
    python -m bus.eds.generate --check  # exit 1 (naming the file) if a shipped file differs

The output is deterministic: FileInfo's dates are the constants ``EDS_DATE``/``EDS_TIME`` of
:mod:`bus.eds.objects` (the date of the table's last change, not the time of generation), so a
test can compare the shipped files with :func:`render_eds` byte for byte.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Dict, List

from bus.eds.objects import (EDS_DATE, EDS_TIME, INTEGER32, KINDS, kind_spec, SOFTWARE_VERSION, VAR, VENDOR_ID,
                             Entry, Kind, Obj)

__all__ = ["render_eds", "write_all", "check_all", "EDS_DIR", "main"]

EDS_DIR = Path(__file__).resolve().parent
_SIGNED = {0x02, 0x03, INTEGER32, 0x10, 0x15}
_HEX_DIGITS = {0x05: 2, 0x06: 4, 0x16: 6, 0x07: 8}
_BAUD_RATES_KBIT = (10, 20, 50, 125, 250, 500, 800, 1000)
_BITRATE_KBIT = 1000        # the paper's bus: 1 Mbit/s


def _value(e: Entry, v) -> str:
    if isinstance(v, str):
        return v
    if e.data_type in _SIGNED:
        return str(int(v))          # negative values in decimal (canopen reads them; CiA 306)
    return f"0x{int(v):0{_HEX_DIGITS.get(e.data_type, 1)}X}"   # 0x00050008: as EDS tools expect


def _entry_lines(section: str, e: Entry, with_type: bool = True) -> List[str]:
    lines = [f"[{section}]", f"ParameterName={e.name}", f"ObjectType=0x{VAR:X}",
             f"DataType=0x{e.data_type:04X}", f"AccessType={e.access}"]
    if e.default is not None:
        lines.append(f"DefaultValue={_value(e, e.default)}")
    if e.low is not None:
        lines.append(f"LowLimit={_value(e, e.low)}")
    if e.high is not None:
        lines.append(f"HighLimit={_value(e, e.high)}")
    lines.append(f"PDOMapping={int(e.pdo_mapping)}")
    return lines + [""]


def _object_lines(o: Obj) -> List[str]:
    if o.object_type == VAR:
        e = o.entries[0]
        return _entry_lines(f"{o.index:04X}", Entry(0, o.name, e.data_type, e.access, e.default,
                                                     e.low, e.high, e.pdo_mapping))
    lines = [f"[{o.index:04X}]", f"ParameterName={o.name}", f"ObjectType=0x{o.object_type:X}",
             f"SubNumber={len(o.entries)}", ""]
    for e in o.entries:
        lines += _entry_lines(f"{o.index:04X}sub{e.subindex:X}", e)
    return lines


def _list_section(name: str, indices: List[int]) -> List[str]:
    lines = [f"[{name}]", f"SupportedObjects={len(indices)}"]
    lines += [f"{i + 1}=0x{idx:04X}" for i, idx in enumerate(indices)]
    return lines + [""]


def render_eds(kind: str) -> str:
    """The EDS text of board kind ``kind`` (a key of :data:`bus.eds.objects.KINDS`).

    Raises
    ------
    KeyError
        For an unknown kind (the message lists the valid ones).
    """
    k: Kind = kind_spec(kind)
    objs = k.objects()
    mandatory = [o.index for o in objs if o.index in (0x1000, 0x1001, 0x1018)]
    optional = [o.index for o in objs if o.index < 0x2000 and o.index not in mandatory]
    manufacturer = [o.index for o in objs if 0x2000 <= o.index < 0x6000]
    lines = [
        "[FileInfo]", f"FileName={k.name}.eds", "FileVersion=1", "FileRevision=0",
        "EDSVersion=4.0", f"Description={k.product_name} ({k.hardware}), {SOFTWARE_VERSION}",
        f"CreationTime={EDS_TIME}", f"CreationDate={EDS_DATE}",
        f"CreatedBy=bus/eds/generate.py from bus/eds/objects.py ({SOFTWARE_VERSION})",
        f"ModificationTime={EDS_TIME}", f"ModificationDate={EDS_DATE}",
        "ModifiedBy=bus/eds/generate.py", "",
        "[DeviceInfo]", "VendorName=schmidt-fil", f"VendorNumber=0x{VENDOR_ID:08X}",
        f"ProductName={k.product_name}", f"ProductNumber=0x{k.product_code:08X}",
        f"RevisionNumber=0x{k.object(0x1018).entry(3).default:08X}", "OrderCode=",
    ]
    lines += [f"BaudRate_{r}={int(r == _BITRATE_KBIT)}" for r in _BAUD_RATES_KBIT]
    lines += ["SimpleBootUpMaster=0", "SimpleBootUpSlave=1", "Granularity=0",
              "DynamicChannelsSupported=0", "GroupMessaging=0",
              f"NrOfRXPDO={len(k.rpdos)}", f"NrOfTXPDO={len(k.tpdos)}", "LSS_Supported=0", "",
              "[DummyUsage]"] + [f"Dummy{i:04d}=0" for i in range(1, 8)] + [""]
    comments = [f"Nodes: {', '.join(str(n) for n in k.nodes)}. Generated; do not edit by hand.",
                "Objects without DefaultValue are set by the firmware's configuration: read them by SDO.",
                "PDOs carry the paper's 8-byte frames (byte 0: device type), see docs/canopen.md."]
    lines += ["[Comments]", f"Lines={len(comments)}"]
    lines += [f"Line{i + 1}={c}" for i, c in enumerate(comments)] + [""]
    lines += _list_section("MandatoryObjects", mandatory)
    lines += _list_section("OptionalObjects", optional)
    lines += _list_section("ManufacturerObjects", manufacturer)
    for o in objs:
        lines += _object_lines(o)
    return "\n".join(lines)


def eds_file(kind: str) -> Path:
    """Path of the shipped EDS file of ``kind``."""
    return EDS_DIR / f"{kind}.eds"


def write_all(directory: Path = EDS_DIR) -> List[Path]:
    """Write every kind's EDS into ``directory``; returns the paths."""
    out = []
    for kind in KINDS:
        p = Path(directory) / f"{kind}.eds"
        p.write_text(render_eds(kind), encoding="ascii", newline="\n")
        out.append(p)
    return out


def check_all(directory: Path = EDS_DIR) -> Dict[str, str]:
    """Kinds whose shipped file differs from :func:`render_eds` → a one-line reason."""
    bad = {}
    for kind in KINDS:
        p = Path(directory) / f"{kind}.eds"
        if not p.exists():
            bad[kind] = f"{p}: missing"
        elif p.read_text(encoding="ascii") != render_eds(kind):
            bad[kind] = f"{p}: differs from bus/eds/objects.py (run python -m bus.eds.generate)"
    return bad


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bus.eds.generate", description=__doc__.split("\n")[0])
    ap.add_argument("--check", action="store_true", help="compare instead of writing")
    args = ap.parse_args(argv)
    if args.check:
        bad = check_all()
        for reason in bad.values():
            print(reason, file=sys.stderr)
        return 1 if bad else 0
    for p in write_all():
        print(p)
    return 0


if __name__ == "__main__":
    sys.exit(main())
