"""The gateway's 64-byte report codec (bus/hid_reports.py): round trips and refusals."""

import struct

import pytest
from hypothesis import given, strategies as st

from bus import hid_reports as R

frame = st.tuples(st.integers(0, 0x7FF), st.binary(max_size=8), st.integers(0, 2**32 - 1))


@given(st.lists(frame, max_size=R.FRAMES_PER_REPORT), st.integers(0, 255), st.integers(0, 255))
def test_in_report_round_trip(frames, flags, seq):
    """Every IN report of 0..4 frames decodes to the same ids, data, timestamps, flags, seq."""
    b = R.encode_report(R.KIND_IN, frames, flags, seq)
    assert len(b) == 64
    rep = R.decode_report(b, R.KIND_IN)
    assert rep.flags == flags and rep.seq == seq
    assert [tuple(f) for f in rep.frames] == [(i, d, t) for i, d, t in frames]


@given(st.lists(frame, max_size=R.FRAMES_PER_REPORT))
def test_out_report_round_trip_ignores_timestamps(frames):
    """OUT reports carry ids and data; the timestamp field is reserved (decoded as 0)."""
    rep = R.decode_report(R.encode_report(R.KIND_OUT, frames), R.KIND_OUT)
    assert [tuple(f) for f in rep.frames] == [(i, d, 0) for i, d, _ in frames]


def test_report_layout_matches_the_document():
    """Byte positions as docs/usb-gateway.md gives them (written by hand here, not by the codec)."""
    b = R.encode_report(R.KIND_IN, [(0x705, b"\x05\x01", 0x01020304)], flags=R.InFlags.RX_OVERFLOW, seq=7)
    assert b[:4] == bytes([0x81, 1, 0x01, 7])
    assert b[4:6] == bytes([0x05, 0x07]) and b[6] == 2 and b[7:9] == b"\x05\x01" and b[9:15] == bytes(6)
    assert b[15:19] == bytes([4, 3, 2, 1]) and b[19:] == bytes(45)
    assert R.FRAMES_PER_REPORT == 4


@given(st.integers(0, 2**32 - 1), st.integers(0, 2**40), st.integers(0, 2**17), st.integers(0, 255))
def test_status_round_trip_saturates(uptime, big, level, flags):
    """Status counters saturate at 2**32−1 / 2**16−1; uptime wraps; the rest round-trips."""
    s = R.Status(flags=flags, filters=3, uptime_us=uptime, rx_frames=big, rx_dropped=5, queue_depth=32,
                 queue_level=level, last_malformed=2)
    d = R.decode_status(R.encode_status(s))
    assert d.rx_frames == min(big, 2**32 - 1) and d.queue_level == min(level, 2**16 - 1)
    assert (d.flags, d.filters, d.uptime_us, d.rx_dropped, d.queue_depth, d.last_malformed) == (flags, 3, uptime, 5, 32, 2)


@given(st.lists(st.tuples(st.integers(0, 0x7FF), st.integers(0, 0x7FF)), max_size=R.MAX_FILTERS))
def test_set_filters_round_trip(filters):
    """SET_FILTERS with 0..6 (id, mask) pairs round-trips."""
    c = R.decode_command(R.encode_command(R.CMD_SET_FILTERS, filters))
    assert c.cmd == R.CMD_SET_FILTERS and [tuple(f) for f in c.filters] == filters


@pytest.mark.parametrize("mutate,reason", [
    (lambda b: b[:63], R.MalformedReason.LENGTH),
    (lambda b: b"\x02" + b[1:], R.MalformedReason.KIND),
    (lambda b: b[:1] + b"\x05" + b[2:], R.MalformedReason.COUNT),
    (lambda b: b[:4] + struct.pack("<H", 0x800) + b[6:], R.MalformedReason.ID),
    (lambda b: b[:6] + b"\x09" + b[7:], R.MalformedReason.DLC),
])
def test_malformed_out_reports_name_the_field(mutate, reason):
    """Each kind of bad OUT report raises ReportError with its reason and names the field."""
    good = R.encode_report(R.KIND_OUT, [(0x123, b"\x01")])
    with pytest.raises(R.ReportError) as e:
        R.decode_report(mutate(good), R.KIND_OUT)
    assert e.value.reason == reason and "OUT report" in str(e.value)


def test_bad_commands_refused():
    """Unknown command byte and more than 6 filters are refused."""
    with pytest.raises(R.ReportError):
        R.decode_command(b"\x09" + bytes(63))
    with pytest.raises(R.ReportError):
        R.decode_command(bytes([R.CMD_SET_FILTERS, 7]) + bytes(62))
    with pytest.raises(R.ReportError):
        R.decode_command(bytes([R.CMD_SET_FILTERS, 1, 0x00, 0x08, 0xFF, 0x07]) + bytes(58))


def test_decode_in_frames_agrees_with_decode_report():
    """The host's fast IN decoder (plain tuples) gives decode_report's flags, seq and frames, and
    refuses exactly the reports decode_report refuses, with the same error text: random reports,
    most with one or two bytes corrupted or a wrong length."""
    import random

    rng = random.Random(12)
    refused = 0
    for _ in range(5000):
        frames = [(rng.randint(0, 0x7FF), bytes(rng.randrange(256) for _ in range(rng.randint(0, 8))),
                   rng.randint(0, 2**32 - 1)) for _ in range(rng.randint(0, R.FRAMES_PER_REPORT))]
        rep = bytearray(R.encode_report(R.KIND_IN, frames, rng.randint(0, 255), rng.randint(0, 255)))
        for _ in range(rng.randint(0, 2)):
            rep[rng.randrange(R.REPORT_SIZE)] = rng.randrange(256)
        if rng.random() < 0.05:
            rep = rep[:rng.randrange(R.REPORT_SIZE + 6)]
        try:
            ref = R.decode_report(bytes(rep), R.KIND_IN)
        except R.ReportError as exc:
            refused += 1
            with pytest.raises(R.ReportError) as got:
                R.decode_in_frames(bytes(rep))
            assert str(got.value) == str(exc)
            continue
        assert R.decode_in_frames(bytes(rep)) == (ref.flags, ref.seq, [tuple(f) for f in ref.frames])
    assert 200 < refused < 4800


def test_pack_report_is_encode_report_of_slot_fields():
    """The gateway's unchecked IN packer gives encode_report's bytes for the same frames."""
    import random

    rng = random.Random(5)
    for _ in range(2000):
        frames = [(rng.randint(0, 0x7FF), bytes(rng.randrange(256) for _ in range(rng.randint(0, 8))),
                   rng.randint(0, 2**32 - 1)) for _ in range(rng.randint(0, R.FRAMES_PER_REPORT))]
        flags, seq = rng.randint(0, 255), rng.randint(0, 255)
        vals = [R.KIND_IN, len(frames), flags, seq]
        for aid, data, ts in frames:
            vals += (aid, len(data), data, ts)
        assert R.pack_report(len(frames), vals) == R.encode_report(R.KIND_IN, frames, flags, seq)
