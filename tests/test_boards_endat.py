"""Specification of the EnDat-2.2-style position frame and the PIC18F4480 position reader."""

import pytest
from hypothesis import given
from hypothesis import strategies as st

from boards.endat import (CRC_POLY, EnDatMaster, build_position_frame, build_position_word,
                          crc5, crc5_word, parse_position_frame, parse_position_word, word_to_bits)
from boards.position_reader import ARCSEC_PER_COUNT, PositionReader
from bus import protocol as p
from bus.scheduler import Scheduler
from boards_fakes import FakeBus, nmt_start

positions = st.integers(0, (1 << 29) - 1)


def crc_by_long_division(bits):
    """Independent reference: remainder of (preset-adjusted) message × x^5 mod G, complemented."""
    # preset 11111 is equivalent to XOR-ing ones into the first 5 message bits
    msg = list(bits) + [0] * 5
    for i in range(min(5, len(bits))):
        msg[i] ^= 1
    if len(bits) < 5:
        raise ValueError("reference needs >= 5 bits")
    gen = [1, 0, 1, 0, 1, 1]          # x^5 + x^3 + x + 1
    for i in range(len(bits)):
        if msg[i]:
            for j, g in enumerate(gen):
                msg[i + j] ^= g
    rem = msg[-5:]
    return int("".join(str(1 - b) for b in rem), 2)


def test_generator_is_x5_x3_x_1():
    """The generator polynomial is 0x0B (x^5 + x^3 + x + 1)."""
    assert CRC_POLY == 0x0B


@pytest.mark.parametrize("bits,expected", [
    ([0] * 31, 10),            # F1 F2 = 0, position 0
    ([1] * 31, 1),
    ([0, 0, 1] + [0] * 28, 2),  # position 1
])
def test_crc_known_vectors(bits, expected):
    """Fixed vectors (regression values, cross-checked by polynomial long division)."""
    assert crc5(bits) == expected
    assert crc_by_long_division(bits) == expected


@given(st.lists(st.integers(0, 1), min_size=5, max_size=64))
def test_shift_register_equals_long_division(bits):
    """The shift-register CRC equals the long-division definition for any message."""
    assert crc5(bits) == crc_by_long_division(bits)


@given(st.lists(st.integers(0, 1), min_size=1, max_size=40))
def test_table_crc_equals_shift_register(bits):
    """The table-driven CRC of the reader's fast path equals the bit-serial shift register."""
    word = sum(b << i for i, b in enumerate(bits))
    assert crc5_word(word, len(bits)) == crc5(bits)


@given(pos=positions, f1=st.integers(0, 1), f2=st.integers(0, 1),
       flips=st.sets(st.integers(0, 36), max_size=4))
def test_word_frames_equal_bit_list_frames(pos, f1, f2, flips):
    """The int-register frame (fast path) is the bit-list frame, and both parsers agree on it,
    corrupted or not."""
    bits = build_position_frame(pos, f1=f1, f2=f2)
    word = build_position_word(pos, f1=f1, f2=f2)
    assert word_to_bits(word, 37) == bits
    for n in flips:
        bits[n] ^= 1
        word ^= 1 << n
    assert parse_position_word(word, 37) == parse_position_frame(bits)


@given(pos=positions, n=st.integers(0, 36))
def test_every_single_flipped_bit_is_detected(pos, n):
    """Any single corrupted bit of the 37-bit frame makes the reading unusable."""
    frame = build_position_frame(pos)
    assert parse_position_frame(frame).position == pos
    frame[n] ^= 1
    r = parse_position_frame(frame)
    assert r.position is None and not r.valid
    m = EnDatMaster(lambda: pos)
    m.flip_bit(n)
    assert m.read().position is None and m.crc_errors == 1 and m.last_frame == frame


@given(pos=positions)
def test_frame_layout_start_f1_f2_lsb_first(pos):
    """Frame = S, F1, F2, 29 position bits LSB first, 5 CRC bits."""
    f = build_position_frame(pos)
    assert len(f) == 37 and f[0] == 1 and f[1:3] == [0, 0]
    assert sum(b << i for i, b in enumerate(f[3:32])) == pos


def test_master_counts_crc_errors_and_fault_injection_is_one_shot():
    """flip_bit corrupts the next frame only; the master counts it."""
    m = EnDatMaster(lambda: 12345)
    m.flip_bit(10)
    assert m.read().position is None and m.crc_errors == 1
    assert m.read().position == 12345 and m.crc_errors == 1


def make_reader(word, **kw):
    s = Scheduler()
    bus = FakeBus()
    r = PositionReader(s, bus, 3, read_position_word=lambda: word[0], **kw)
    r.start()
    nmt_start(r)
    return s, bus, r


def deg_to_counts(deg):
    return int(round(deg * 3600 / ARCSEC_PER_COUNT)) % (1 << 29)


def test_position_published_every_10_ms_with_offset():
    """POSITION every 10 ms carries (raw + offset) mod 2**29."""
    word = [1000]
    s, bus, r = make_reader(word, offset_counts=24)
    s.run_until(100_000)
    frames = [p.decode_position(m.data) for m in bus.frames(p.position_cob_id(3))]
    assert len(frames) == 10 and frames[-1].pos_counts == 1024 and frames[-1].flags == 0


def test_crc_error_keeps_last_good_position_and_flags_it():
    """A corrupted read is counted, not used, flagged (bit2) and reported with EMCY ENDAT_CRC,
    cleared (EMCY error reset) by the next good read."""
    word = [5000]
    s, bus, r = make_reader(word)
    s.run_until(10_000)
    word[0] = 6000
    r.flip_bit(7)
    s.run_until(20_000)
    pos = p.decode_position(bus.frames(p.position_cob_id(3))[-1].data)
    assert pos.pos_counts == 5000 and pos.flags & p.PositionFlags.CRC_ERROR and pos.crc_errors == 1
    fault = p.decode_emcy(bus.frames(p.emcy_cob_id(3))[-1].data)
    assert fault.fault_code == p.FaultCode.ENDAT_CRC and fault.error_code == 0x7300
    assert fault.detail == r.endat.reads and fault.error_register & 0x81 == 0x81
    s.run_until(30_000)
    pos = p.decode_position(bus.frames(p.position_cob_id(3))[-1].data)
    assert pos.pos_counts == 6000 and pos.flags == 0
    reset = p.decode_emcy(bus.frames(p.emcy_cob_id(3))[-1].data)
    assert reset.error_code == 0 and reset.detail == 0x7300 and reset.error_register == 0


def test_limit_frames_on_change_and_every_100_ms_while_active():
    """Entering the high limit sends LIMIT at once, then every 100 ms; leaving sends one clear.
    (93.0° is outside the approach zone of 1.245°; 95.5° is inside both zones.)"""
    word = [deg_to_counts(93.0)]
    s, bus, r = make_reader(word)
    s.run_until(50_000)
    assert bus.frames(p.limit_cob_id(3)) == []
    word[0] = deg_to_counts(95.5)
    s.run_until(360_000)                    # entered at 60 ms → frames at 60, 160, 260, 360 ms
    lims = [p.decode_limit(m.data) for m in bus.frames(p.limit_cob_id(3))]
    both = p.LimitFlags.HIGH_SOFT_LIMIT | p.LimitFlags.HIGH_NEAR
    assert len(lims) == 4 and all(l.flags == both for l in lims)
    assert lims[0].axis == p.Axis.RA
    word[0] = deg_to_counts(93.0)           # back outside both zones
    s.run_until(600_000)
    lims = [p.decode_limit(m.data) for m in bus.frames(p.limit_cob_id(3))]
    assert len(lims) == 5 and lims[-1].flags == 0


def test_approach_zone_flags_in_position_and_limit_frames():
    """Within the braking distance of the highest commanded rate (boards/safety.py: 3°/s →
    1.245°) of a limit, POSITION and LIMIT frames carry the near bit; the soft-limit bit only
    where braking must begin; the near bit clears outside the zone plus the hysteresis."""
    from boards.safety import DEFAULT_SAFETY
    near_deg = DEFAULT_SAFETY.braking_distance_arcsec(DEFAULT_SAFETY.max_rate_arcsec_s) / 3600
    assert near_deg == pytest.approx(1.245, abs=0.001)
    word = [deg_to_counts(95.0 - near_deg + 0.01)]
    s, bus, r = make_reader(word)
    s.run_until(20_000)
    pos = p.decode_position(bus.frames(p.position_cob_id(3))[-1].data)
    assert pos.flags == p.PositionFlags.HIGH_NEAR
    lim = p.decode_limit(bus.frames(p.limit_cob_id(3))[-1].data)
    assert lim.flags == p.LimitFlags.HIGH_NEAR
    word[0] = deg_to_counts(95.0 - near_deg - 5 / 3600)       # outside by 5″ < 10″ hysteresis
    s.run_until(40_000)
    assert p.decode_position(bus.frames(p.position_cob_id(3))[-1].data).flags == p.PositionFlags.HIGH_NEAR
    word[0] = deg_to_counts(95.0 - near_deg - 15 / 3600)
    s.run_until(60_000)
    assert p.decode_position(bus.frames(p.position_cob_id(3))[-1].data).flags == 0
    assert p.decode_limit(bus.frames(p.limit_cob_id(3))[-1].data).flags == 0


def test_low_limit_and_hysteresis():
    """The low limit stays active until the angle is back inside by the hysteresis."""
    word = [deg_to_counts(-95.0 - 1 / 3600)]
    s, bus, r = make_reader(word)
    s.run_until(10_000)
    assert r.limit_flags == p.LimitFlags.LOW_SOFT_LIMIT
    word[0] = deg_to_counts(-95.0 + 5 / 3600)
    s.run_until(20_000)
    assert r.limit_flags == p.LimitFlags.LOW_SOFT_LIMIT
    word[0] = deg_to_counts(-95.0 + 15 / 3600)
    s.run_until(30_000)
    assert r.limit_flags == 0


def test_reader_limit_frame_drives_axis_controller():
    """End to end on one fake bus pair: the reader's LIMIT frame stops the axis controller."""
    from boards.axis_controller import AxisController, AxisMode
    word = [deg_to_counts(96.0)]
    s = Scheduler()
    bus_r, bus_a = FakeBus(), FakeBus()
    r = PositionReader(s, bus_r, 3, read_position_word=lambda: word[0])
    ax = AxisController(s, bus_a, 1, read_qei_counts=lambda: 0)
    r.start(); ax.start()
    nmt_start(r, ax)
    bus_a.inject(p.axis_command_cob_id(1), p.encode_axis_command(p.AxisCommand.SLEW, 1))
    s.run_until(10_000)
    for m in bus_r.frames(p.limit_cob_id(3)):
        bus_a.inject(m.arbitration_id, m.data)
    assert ax.mode == AxisMode.LIMIT_STOP
