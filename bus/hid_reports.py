"""Report codec of the USB-HID CAN gateway (docs/usb-gateway.md): 64-byte IN, OUT and feature reports.

Pure functions on ``bytes``; no python-can, no USB transport (STYLE.md §7). The firmware
(:mod:`boards.usb_gateway`), the in-process ``hid.device`` look-alike (:mod:`host.hid_device`)
and the ``/dev/uhid`` bridge (:mod:`host.uhid_gateway`) all use these; an external host program
is written from docs/usb-gateway.md alone.

Layout (all multi-byte fields little-endian; the device uses no report IDs, so on the wire a
report is exactly 64 bytes and hidapi/hidraw prepend the report number 0):

* **IN / OUT report** = 4-byte header + :data:`FRAMES_PER_REPORT` (4) slots of 15 bytes.
  Header: ``kind`` (:data:`KIND_OUT` 0x01 PC→gateway, :data:`KIND_IN` 0x81 gateway→PC),
  ``count`` (0..4 frames used), ``flags`` (IN: :class:`InFlags`; OUT: 0), ``seq`` (u8, wraps).
  Slot: ``id`` u16 (11-bit identifier; bits 11..15 zero), ``dlc`` u8 (0..8), ``data`` 8 bytes
  (bytes past the DLC zero), ``timestamp_us`` u32 (IN: gateway time of the frame's reception,
  µs since gateway boot, wraps after 71.6 min; OUT: reserved, ignored).
* **Feature report, GET** (status, :class:`Status`): see :data:`_S_STATUS`.
* **Feature report, SET** (commands): ``cmd`` byte then arguments; :data:`CMD_SET_FILTERS`
  (``n`` ≤ 6 then ``n`` × (id u16, mask u16)), :data:`CMD_CLEAR_COUNTERS`.
"""

from __future__ import annotations

import struct
from enum import IntEnum, IntFlag
from typing import Final, NamedTuple, Sequence

from bus.errors import FrameError

__all__ = [
    "REPORT_SIZE", "FRAMES_PER_REPORT", "MAX_FILTERS", "KIND_OUT", "KIND_IN", "STATUS_VERSION",
    "CMD_SET_FILTERS", "CMD_CLEAR_COUNTERS", "InFlags", "MalformedReason", "ReportError", "Frame",
    "Report", "Filter", "Status", "Command", "encode_report", "decode_report", "encode_status",
    "decode_status", "encode_command", "decode_command", "filter_matches",
]

#: Bytes of every report (paper §3.4: "A total of 64 bytes are exchanged"; full-speed interrupt
#: endpoints carry at most 64 bytes per 1 ms frame, USB 2.0 §5.7.3).
REPORT_SIZE: Final = 64
_S_HEADER: Final = struct.Struct("<BBBB")
_S_SLOT: Final = struct.Struct("<HB8sI")
#: bytes of the header (kind, count, flags, seq), where the first slot starts
_HEADER_BYTES: Final = _S_HEADER.size
#: CAN frames per report, each way: (64 − 4 header) // 15-byte slot = 4.
FRAMES_PER_REPORT: Final = (REPORT_SIZE - _S_HEADER.size) // _S_SLOT.size
#: the slots of a report with n frames, and the whole report (header + n slots, zero padded
#: to REPORT_SIZE), as one precompiled Struct each, n = 0..FRAMES_PER_REPORT
_S_SLOTS: Final = tuple(struct.Struct("<" + "HB8sI" * n) for n in range(FRAMES_PER_REPORT + 1))
_S_REPORT: Final = tuple(struct.Struct("<BBBB" + "HB8sI" * n + f"{REPORT_SIZE - 4 - 15 * n}x")
                  for n in range(FRAMES_PER_REPORT + 1))
#: Acceptance filters the gateway holds (assumed: the MCP2515 CAN controller beside the
#: PIC18F4550 has six acceptance filters; here each has its own mask).
MAX_FILTERS: Final = 6
KIND_OUT: Final = 0x01
KIND_IN: Final = 0x81
STATUS_VERSION: Final = 1
CMD_SET_FILTERS: Final = 0x01
CMD_CLEAR_COUNTERS: Final = 0x02


class InFlags(IntFlag):
    """Flags byte of an IN report: what happened since the previous IN report."""

    RX_OVERFLOW = 0x01      #: CAN→PC queue was full: frames were dropped (count in status)
    OUT_MALFORMED = 0x02    #: a malformed OUT report or feature command was refused
    CAN_TX_ERROR = 0x04     #: the CAN controller refused a frame (bus error)
    CAN_HW_OVERRUN = 0x08   #: the CAN controller's two receive buffers overflowed


class MalformedReason(IntEnum):
    """Why the gateway refused an OUT report or a feature command (status ``last_malformed``)."""

    NONE = 0
    LENGTH = 1        #: not exactly 64 bytes
    KIND = 2          #: header kind is not 0x01 (OUT) / unknown command
    COUNT = 3         #: more than 4 frames
    ID = 4            #: identifier above 0x7FF (bits 11..15 set)
    DLC = 5           #: DLC above 8
    FILTERS = 6       #: more than 6 filters, or a filter id/mask above 0x7FF


class ReportError(FrameError):
    """A report that does not decode; ``reason`` is a :class:`MalformedReason`."""

    def __init__(self, report: str, field: str, expected: str, got: object, reason: MalformedReason) -> None:
        super().__init__(report, field, expected, got)
        self.reason = reason


class Frame(NamedTuple):
    """One CAN frame in a report slot."""

    arbitration_id: int     #: 11-bit identifier
    data: bytes             #: 0..8 bytes (the DLC is its length)
    timestamp_us: int = 0   #: IN: µs since gateway boot, mod 2**32; OUT: 0


class Report(NamedTuple):
    """A decoded IN or OUT report."""

    kind: int
    frames: tuple
    flags: int = 0
    seq: int = 0


class Filter(NamedTuple):
    """Acceptance filter: a frame passes when ``id & mask == filter_id & mask``."""

    filter_id: int
    mask: int = 0x7FF


class Command(NamedTuple):
    """A decoded SET feature command."""

    cmd: int
    filters: tuple = ()


class Status(NamedTuple):
    """The GET feature report (counters saturate at 2**32 − 1, levels at 2**16 − 1)."""

    version: int = STATUS_VERSION
    flags: int = 0              #: InFlags raised since power-on / the last CLEAR_COUNTERS
    filters: int = 0            #: number of active acceptance filters (0 = accept all)
    node_id: int = 0x10         #: the gateway's CAN node id
    uptime_us: int = 0          #: µs since boot, mod 2**32
    rx_frames: int = 0          #: CAN frames queued for the PC
    rx_dropped: int = 0         #: CAN frames dropped because the queue was full
    tx_frames: int = 0          #: frames sent on CAN for the PC
    tx_errors: int = 0          #: frames the CAN controller refused
    in_reports: int = 0         #: IN reports taken by the PC
    out_reports: int = 0        #: OUT reports received (good and malformed)
    out_malformed: int = 0      #: OUT reports and feature commands refused
    queue_depth: int = 0        #: capacity of the CAN→PC queue, frames
    queue_level: int = 0        #: frames waiting now
    queue_high_water: int = 0   #: most frames ever waiting
    hw_overruns: int = 0        #: CAN controller receive-buffer overruns
    last_malformed: int = 0     #: MalformedReason of the last refused report


_S_STATUS: Final = struct.Struct("<BBBBIIIIIIIIHHHHB")
_U32, _U16 = (1 << 32) - 1, (1 << 16) - 1


def _fail(report: str, field: str, expected: str, got, reason: MalformedReason):
    raise ReportError(report, field, expected, got, reason)


def encode_report(kind: int, frames: Sequence, flags: int = 0, seq: int = 0) -> bytes:
    """Encode an IN or OUT report.

    Parameters
    ----------
    kind : {KIND_IN, KIND_OUT}
    frames : sequence of Frame or (arbitration_id, data[, timestamp_us])
        At most :data:`FRAMES_PER_REPORT`.
    flags : int
        InFlags (IN) or 0.
    seq : int
        Report counter, taken mod 256.

    Returns
    -------
    bytes
        Exactly 64 bytes.

    Raises
    ------
    ReportError
        Too many frames, an id above 0x7FF or more than 8 data bytes (a bug in the sender).
    """
    name = "IN report" if kind == KIND_IN else "OUT report"
    if kind not in (KIND_IN, KIND_OUT):
        _fail(name, "kind", "0x01 or 0x81", kind, MalformedReason.KIND)
    if len(frames) > FRAMES_PER_REPORT:
        _fail(name, "count", f"0..{FRAMES_PER_REPORT}", len(frames), MalformedReason.COUNT)
    vals: list = [kind, len(frames), flags & 0xFF, seq & 0xFF]
    for f in frames:
        aid, data = int(f[0]), bytes(f[1])
        if not 0 <= aid <= 0x7FF:
            _fail(name, "id", "0..0x7FF", aid, MalformedReason.ID)
        if len(data) > 8:
            _fail(name, "dlc", "0..8", len(data), MalformedReason.DLC)
        vals += (aid, len(data), data, (int(f[2]) if len(f) > 2 else 0) & _U32)
    # one precompiled Struct per frame count (``8s`` pads the data with zeros)
    return _S_REPORT[len(frames)].pack(*vals)


def pack_report(n: int, values) -> bytes:
    """The 64-byte report of ``n`` frames from its fields in order, unchecked: kind, n, flags,
    seq, then per frame id, DLC, data (padded with zeros), timestamp_us (:func:`encode_report`
    checks and normalises its arguments, then packs the same way; the gateway firmware's IN
    path, whose frames come off the CAN bus, packs directly)."""
    return _S_REPORT[n].pack(*values)


def decode_report(report, expect_kind: int) -> Report:
    """Decode a 64-byte IN or OUT report; raises :class:`ReportError` naming the field.

    Unused slots and bytes past a frame's DLC are ignored; ``timestamp_us`` of OUT frames is
    returned as 0 (reserved).
    """
    name = "IN report" if expect_kind == KIND_IN else "OUT report"
    b = bytes(report)
    if len(b) != REPORT_SIZE:
        _fail(name, "length", f"{REPORT_SIZE} bytes", len(b), MalformedReason.LENGTH)
    kind, count, flags, seq = _S_HEADER.unpack_from(b, 0)
    if kind != expect_kind:
        _fail(name, "kind", f"0x{expect_kind:02X}", kind, MalformedReason.KIND)
    if count > FRAMES_PER_REPORT:
        _fail(name, "count", f"0..{FRAMES_PER_REPORT}", count, MalformedReason.COUNT)
    vals = _S_SLOTS[count].unpack_from(b, _S_HEADER.size)
    frames = []
    for i in range(count):
        aid, dlc, data, ts = vals[4 * i:4 * i + 4]
        if aid > 0x7FF:
            _fail(name, f"frame[{i}].id", "0..0x7FF", aid, MalformedReason.ID)
        if dlc > 8:
            _fail(name, f"frame[{i}].dlc", "0..8", dlc, MalformedReason.DLC)
        frames.append(Frame(aid, data[:dlc], ts if expect_kind == KIND_IN else 0))
    return Report(kind, tuple(frames), flags, seq)


def decode_in_frames(report) -> tuple:
    """:func:`decode_report` of an IN report, as ``(flags, seq, frames)`` with each frame a plain
    ``(arbitration_id, data, timestamp_us)`` tuple (no :class:`Frame`/:class:`Report` objects: the
    host's receive path, every report). Same checks; a report :func:`decode_report` refuses
    raises the same :class:`ReportError`."""
    b: bytes = bytes(report)
    if len(b) == REPORT_SIZE and b[0] == KIND_IN:
        # header bytes read directly and the slots unpacked once; typed locals, so the compiled
        # module compares and indexes natively (session 17)
        count: int = b[1]
        if count <= FRAMES_PER_REPORT:
            vals: tuple = _S_SLOTS[count].unpack_from(b, _HEADER_BYTES)
            frames: list = []
            for i in range(0, 4 * count, 4):
                aid: int = vals[i]
                dlc: int = vals[i + 1]
                if aid > 0x7FF or dlc > 8:
                    break
                data: bytes = vals[i + 2]
                frames.append((aid, data if dlc == 8 else data[:dlc], vals[i + 3]))
            else:
                return b[2], b[3], frames
    rep = decode_report(b, KIND_IN)          # raises ReportError naming the field
    return rep.flags, rep.seq, [tuple(f) for f in rep.frames]


def encode_status(s: Status) -> bytes:
    """Encode the 64-byte status feature report (counters saturate)."""
    v = list(s)
    for i in range(5, 12):
        v[i] = min(int(v[i]), _U32)
    v[4] = int(v[4]) & _U32
    for i in range(12, 16):
        v[i] = min(int(v[i]), _U16)
    return _S_STATUS.pack(*v).ljust(REPORT_SIZE, b"\0")


def decode_status(report) -> Status:
    """Decode the status feature report (64 bytes, without the report number)."""
    b = bytes(report)
    if len(b) != REPORT_SIZE:
        _fail("status report", "length", f"{REPORT_SIZE} bytes", len(b), MalformedReason.LENGTH)
    return Status(*_S_STATUS.unpack_from(b, 0))


def encode_command(cmd: int, filters: Sequence = ()) -> bytes:
    """Encode a SET feature command (64 bytes).

    Raises
    ------
    ReportError
        Unknown command, more than :data:`MAX_FILTERS` filters or a value above 0x7FF.
    """
    if cmd not in (CMD_SET_FILTERS, CMD_CLEAR_COUNTERS):
        _fail("feature command", "cmd", "0x01 or 0x02", cmd, MalformedReason.KIND)
    out = bytearray(REPORT_SIZE)
    out[0] = cmd
    if cmd == CMD_SET_FILTERS:
        if len(filters) > MAX_FILTERS:
            _fail("SET_FILTERS", "n", f"0..{MAX_FILTERS}", len(filters), MalformedReason.FILTERS)
        out[1] = len(filters)
        for i, f in enumerate(filters):
            fid, mask = (f, 0x7FF) if isinstance(f, int) else (int(f[0]), int(f[1]))
            if not (0 <= fid <= 0x7FF and 0 <= mask <= 0x7FF):
                _fail("SET_FILTERS", f"filter[{i}]", "id and mask 0..0x7FF", (fid, mask), MalformedReason.FILTERS)
            struct.pack_into("<HH", out, 2 + 4 * i, fid, mask)
    return bytes(out)


def decode_command(report) -> Command:
    """Decode a SET feature command (64 bytes, without the report number); raises ReportError."""
    b = bytes(report)
    if len(b) != REPORT_SIZE:
        _fail("feature command", "length", f"{REPORT_SIZE} bytes", len(b), MalformedReason.LENGTH)
    cmd = b[0]
    if cmd == CMD_CLEAR_COUNTERS:
        return Command(cmd)
    if cmd != CMD_SET_FILTERS:
        _fail("feature command", "cmd", "0x01 or 0x02", cmd, MalformedReason.KIND)
    n = b[1]
    if n > MAX_FILTERS:
        _fail("SET_FILTERS", "n", f"0..{MAX_FILTERS}", n, MalformedReason.FILTERS)
    filters = []
    for i in range(n):
        fid, mask = struct.unpack_from("<HH", b, 2 + 4 * i)
        if fid > 0x7FF or mask > 0x7FF:
            _fail("SET_FILTERS", f"filter[{i}]", "id and mask 0..0x7FF", (fid, mask), MalformedReason.FILTERS)
        filters.append(Filter(fid, mask))
    return Command(cmd, tuple(filters))


def filter_matches(filters: Sequence[Filter], arbitration_id: int) -> bool:
    """True when ``arbitration_id`` passes ``filters`` (no filters: every frame passes)."""
    if not filters:
        return True
    return any((arbitration_id & f.mask) == (f.filter_id & f.mask) for f in filters)
