"""RS232 telemetry packets (paper §3.4): codec only, no transport, no python-can.

Paper §3.4: "Time stamped data packets each containing 25 sets of 10 ms samples of PI control
effort, telescope position, telescope velocity, ADC counts and focus position are continuously
transferred to the interfacing PC at a fixed interval of 250 ms on five RS232 serial ports."
The paper gives no byte layout; the one below is **assumed** (designed here) and documented in
``docs/protocol.md``, section "RS232 telemetry". Each board sends what that board has: the axis
controllers their PI/PWM/QEI/ADC quantities, the EnDat readers the absolute position, the
focus controller its half-step counter, motor encoder and LVDT counts.

Packet (all multi-byte fields little-endian, as on the CAN bus)::

    offset size field        meaning
    0      2    sync         0xA5 0x5A
    2      1    version      1
    3      1    device_type  0x01 axis controller, 0x02 position reader, 0x03 focus (as on CAN)
    4      1    node         CAN node id of the sender (1..5)
    5      1    n_samples    25
    6      2    seq          packet counter u16, +1 per packet, wraps; 0 after a board reset
    8      4    t0_us        board uptime at sample 0, µs since boot, u32 (wraps after 4295 s)
    12     2    period_us    sample spacing, µs (10 000)
    14     n·s  samples      n_samples fixed-size samples, layout by device type (below)
    14+n·s 2    crc          CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF) of bytes 2 .. 14+n·s−1

The CRC is :func:`binascii.crc_hqx` (CPython's C implementation). Its generator has the factor
(x + 1), so every odd number of flipped bits is detected, and as a 16-bit CRC it detects every
error burst of up to 16 bits, i.e. any one corrupted byte. The sync bytes are outside the CRC:
a corrupted sync makes the receiver skip the packet (counted as discarded bytes and as a
sequence gap on the next packet).

Sample layouts (:data:`SAMPLE_FIELDS`) — see ``docs/protocol.md`` for units and scaling.
"""

from __future__ import annotations

import binascii
import struct
from typing import NamedTuple

from bus import protocol as _P
from bus.errors import MalformedFrame

__all__ = [
    "SYNC", "VERSION", "SAMPLES_PER_PACKET", "SAMPLE_PERIOD_US", "PACKET_PERIOD_US",
    "HEADER", "SAMPLE_FIELDS", "SAMPLE_STRUCTS", "DEVICE_OF_NODE", "Packet",
    "packet_size", "encode_packet", "decode_packet", "check_header", "payload_struct", "crc16",
    "wire_time_us", "HEADER_SIZE", "DEVICE_AXIS", "DEVICE_READER", "DEVICE_FOCUS",
]

SYNC = b"\xA5\x5A"
VERSION = 1
#: Samples per packet (§3.4: "25 sets of 10 ms samples").
SAMPLES_PER_PACKET = 25
#: Sample spacing, µs (§3.4: 10 ms samples).
SAMPLE_PERIOD_US = 10_000
#: Packet interval, µs (§3.4: "at a fixed interval of 250 ms").
PACKET_PERIOD_US = SAMPLES_PER_PACKET * SAMPLE_PERIOD_US

#: Header after the sync bytes: version, device_type, node, n_samples, seq, t0_us, period_us.
HEADER = struct.Struct("<BBBBHIH")
HEADER_SIZE = len(SYNC) + HEADER.size        # 14
CRC_SIZE = 2
_CRC = struct.Struct("<H")

DEVICE_AXIS, DEVICE_READER, DEVICE_FOCUS = (int(_P.DeviceType.AXIS_CONTROLLER), int(_P.DeviceType.POSITION_READER),
                                         int(_P.DeviceType.FOCUS_CONTROLLER))

#: Sample fields per device type: (name, struct code, unit / scaling). One source of truth for
#: the codec, the host's telemetry.log columns and docs/protocol.md.
SAMPLE_FIELDS: dict[int, tuple[tuple[str, str, str], ...]] = {
    DEVICE_AXIS: (
        ("u_q15", "h", "control effort U, duty Q15: ±32767 = ±100 % (saturating)"),
        ("pdc_a", "H", "PWM duty register motor A, half instruction cycles: duty = pdc/3000"),
        ("pdc_b", "H", "PWM duty register motor B, same scaling"),
        ("qei_counts", "i", "QEI 32-bit extended count (wraps), 0.01148 arcsec/count"),
        ("qei_delta", "h", "QEI counts in the last 5 ms tick: 2.296 (arcsec/s)/count"),
        ("adc_a", "H", "shunt ADC motor A, 10-bit counts: 48.8 mA/count"),
        ("adc_b", "H", "shunt ADC motor B, 10-bit counts"),
        ("setpoint_marcsec_s", "i", "rate setpoint, milli-arcsec/s of axis rate"),
        ("mode", "B", "axis mode (as AXIS_STATUS byte 1)"),
        ("flags", "B", "AXIS_STATUS flags byte"),
    ),
    DEVICE_READER: (
        ("pos_counts", "I", "29-bit absolute position incl. offset, 2**29 counts/rev"),
        ("flags", "B", "POSITION flags byte"),
    ),
    DEVICE_FOCUS: (
        ("pos_halfsteps", "h", "commanded half-step counter, 6.25 um/half-step"),
        ("enc_counts", "i", "motor encoder, 32-bit extended QEI count, 5 counts/half-step"),
        ("lvdt_adc", "H", "LVDT 10-bit ADC counts"),
        ("missed_steps", "H", "half-steps lost since reset (saturating)"),
        ("flags", "B", "FOCUS_STATUS flags byte"),
    ),
}

#: Device type of each board node (from the protocol's node table, the host excluded).
DEVICE_OF_NODE = {int(n): int(d) for n, d in _P.DEVICE_TYPE_OF_NODE.items() if d != _P.DeviceType.HOST}

#: One precompiled struct per device type for a single sample.
SAMPLE_STRUCTS = {d: struct.Struct("<" + "".join(c for _, c, _ in f)) for d, f in SAMPLE_FIELDS.items()}
#: One precompiled struct per device type for a whole packet's samples (one pack/unpack call).
_PAYLOAD = {d: struct.Struct("<" + "".join(c for _, c, _ in f) * SAMPLES_PER_PACKET)
            for d, f in SAMPLE_FIELDS.items()}
#: Header (without sync) + samples in one struct per device type: one pack call per packet.
_BODY = {d: struct.Struct("<BBBBHIH" + "".join(c for _, c, _ in f) * SAMPLES_PER_PACKET)
         for d, f in SAMPLE_FIELDS.items()}


class Packet(NamedTuple):
    """A decoded telemetry packet."""

    device_type: int
    node: int
    seq: int
    t0_us: int
    period_us: int
    samples: tuple          #: tuple of per-sample tuples, fields as :data:`SAMPLE_FIELDS`


def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE of ``data`` (poly 0x1021, init 0xFFFF, no reflection, no xor-out)."""
    return binascii.crc_hqx(data, 0xFFFF)


def packet_size(device_type: int, n_samples: int = SAMPLES_PER_PACKET) -> int:
    """Bytes of one packet of ``device_type`` (axis 566, reader 141, focus 291 for 25 samples)."""
    return HEADER_SIZE + n_samples * SAMPLE_STRUCTS[device_type].size + CRC_SIZE


def wire_time_us(nbytes: int, baud: int, bits_per_byte: int = 10) -> int:
    """Time on an asynchronous line of ``nbytes`` back-to-back bytes, µs (8N1: 10 bits/byte)."""
    return -((-nbytes * bits_per_byte * 1_000_000) // baud)


def encode_packet(device_type: int, node: int, seq: int, t0_us: int, flat_values,
                  period_us: int = SAMPLE_PERIOD_US) -> bytes:
    """Build one packet of :data:`SAMPLES_PER_PACKET` samples.

    Parameters
    ----------
    device_type, node : int
        Sender (node must belong to the device type, :data:`DEVICE_OF_NODE`).
    seq : int
        Packet counter (reduced mod 2**16).
    t0_us : int
        Board uptime of the first sample, µs (reduced mod 2**32).
    flat_values : sequence of int
        The samples' fields, sample after sample (25 × the device type's field count), already
        in range (callers saturate; ``struct.error`` otherwise).
    period_us : int
        Sample spacing, µs.
    """
    body = _BODY[device_type].pack(VERSION, device_type, node, SAMPLES_PER_PACKET, seq & 0xFFFF,
                                   t0_us & 0xFFFFFFFF, period_us, *flat_values)
    return b"".join((SYNC, body, _CRC.pack(binascii.crc_hqx(body, 0xFFFF))))


def check_header(buf, i: int = 0, node: int | None = None):
    """Validate the header starting at ``buf[i]`` (sync included).

    Returns
    -------
    tuple or None
        ``(version, device_type, node, n_samples, seq, t0_us, period_us)`` if plausible, else None
        (wrong version, unknown device type, node not of that type or not ``node``, a sample
        count other than 25, or a zero period).
    """
    h = HEADER.unpack_from(buf, i + 2)
    ver, dev, nd, n, _, _, period = h
    if (ver != VERSION or n != SAMPLES_PER_PACKET or period == 0 or DEVICE_OF_NODE.get(nd) != dev
            or (node is not None and nd != node)):
        return None
    return h


def decode_packet(data: bytes, node: int | None = None) -> Packet:
    """Decode one complete packet; raises :class:`bus.errors.MalformedFrame`.

    Parameters
    ----------
    data : bytes
        Exactly one packet, sync included.
    node : int, optional
        Expected sender (a receiver knows which board is on its port).
    """
    if len(data) < HEADER_SIZE + CRC_SIZE or data[:2] != SYNC:
        raise MalformedFrame("TELEMETRY", "sync", "0xA5 0x5A and at least 16 bytes", data[:2].hex())
    h = check_header(data, 0, node)
    if h is None:
        raise MalformedFrame("TELEMETRY", "header", "version 1, known device/node, 25 samples",
                             data[2:HEADER_SIZE].hex())
    _, dev, nd, n, seq, t0, period = h
    size = packet_size(dev, n)
    if len(data) != size:
        raise MalformedFrame("TELEMETRY", "length", f"{size} bytes", len(data))
    if _CRC.unpack_from(data, size - CRC_SIZE)[0] != crc16(data[2:size - CRC_SIZE]):
        raise MalformedFrame("TELEMETRY", "crc", "CRC-16/CCITT-FALSE of bytes 2..", "mismatch")
    flat = _PAYLOAD[dev].unpack_from(data, HEADER_SIZE)
    k = len(SAMPLE_FIELDS[dev])
    return Packet(dev, nd, seq, t0, period, tuple(flat[j:j + k] for j in range(0, len(flat), k)))


def payload_struct(device_type: int) -> struct.Struct:
    """The precompiled struct of a whole packet's samples (fields flat, sample after sample)."""
    return _PAYLOAD[device_type]
