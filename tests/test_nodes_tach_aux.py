"""Specification of issue 12's motor tachometers (nodes 6-9) and auxiliary encoders (0x0A, 0x0B):
their frames as docs/protocol.md lays them out (decoded with cantools from bus/schmidt.dbc),
their firmware behaviour against independent signal generators, and the plant's sensors."""

from __future__ import annotations

import math
import random
import struct

import pytest

from boards.aux_encoder import AuxEncoder
from boards.tachometer import MIN_COUNTS, Tachometer
from bus import protocol as P
from bus.scheduler import Scheduler
from boards_fakes import FakeBus, nmt_start

CPR = 4000                       # counts per motor revolution used by these tests
ARCSEC_PER_TURN = 1_296_000.0


def _dbc_decode(cob_id: int, data: bytes, scaling: bool = True) -> dict:
    return P.load_dbc().get_message_by_frame_id(cob_id).decode(bytes(data), scaling=scaling, decode_choices=False)


# -------------------------------------------------------------------------------- frame layouts

def test_tach_status_layout_as_documented():
    """TACH_STATUS 0x186..0x189: b0 device type 0x04, b1 window ticks, b2-3 counts u16 LE,
    b4-7 speed i32 LE in µrad/s; the DBC scales it to rad/s (×1e-6)."""
    assert [P.tach_status_cob_id(n) for n in P.TACH_NODES] == [0x186, 0x187, 0x188, 0x189]
    data = P.encode_tach_status(37, 0x12345, -1_234_567)          # counts wrap to 16 bits
    assert data == bytes([0x04, 37]) + struct.pack("<H", 0x2345) + struct.pack("<i", -1_234_567)
    sig = _dbc_decode(0x187, data)
    assert sig["device_type"] == 4 and sig["window_ticks"] == 37 and sig["counts"] == 0x2345
    assert sig["motor_speed"] == pytest.approx(-1.234567)
    assert P.frame_name(0x186) == "TACH_STATUS_RA_1" and P.frame_name(0x189) == "TACH_STATUS_DEC_2"


def test_aux_position_layout_as_documented():
    """AUX_POSITION 0x18A/0x18B: b0 device type 0x05, b1 flags (bit0 turns_unknown), b2-3 zero,
    b4-7 multi-turn count i32 LE."""
    assert [P.aux_position_cob_id(n) for n in P.AUX_NODES] == [0x18A, 0x18B]
    data = P.encode_aux_position(1, -700_001)
    assert data == bytes([0x05, 0x01, 0, 0]) + struct.pack("<i", -700_001)
    sig = _dbc_decode(0x18B, data)
    assert sig["turns_unknown"] == 1 and sig["aux_counts"] == -700_001 and sig["device_type"] == 5


def test_new_frames_refuse_bad_input():
    """Wrong DLC, wrong device type and an out-of-range window are malformed; an invalid window
    or flag does not encode."""
    from bus.errors import EncodeError, MalformedFrame
    good = P.encode_tach_status(1, 0, 0)
    for bad in (good[:7], bytes([0x05]) + good[1:], bytes([0x04, 0]) + good[2:], bytes([0x04, 201]) + good[2:]):
        with pytest.raises(MalformedFrame):
            P.decode(0x186, bad)
    with pytest.raises(MalformedFrame):
        P.decode(0x18A, bytes([0x04]) + P.encode_aux_position(0, 5)[1:])
    with pytest.raises(EncodeError):
        P.encode_tach_status(0, 0, 0)
    with pytest.raises(EncodeError):
        P.encode_aux_position(2, 0)


# -------------------------------------------------------------------------------- tachometer

def _tach(angle_of_t, node=6):
    """A tachometer on a fake bus whose encoder follows ``angle_of_t(t_us)`` [rad] (an
    independent generator: exact floor of angle x CPR / 2π)."""
    s = Scheduler()
    bus = FakeBus()
    t = Tachometer(s, bus, node, read_motor_counts=lambda: math.floor(angle_of_t(s.now_us) * CPR / (2 * math.pi)),
                   counts_per_rev=CPR)
    t.start()
    nmt_start(t)
    return s, bus, t


@pytest.mark.parametrize("omega", [12.583, -3.0, 0.2])
def test_tachometer_speed_within_one_count_of_the_true_speed(omega):
    """At constant motor speed every TACH_STATUS (decoded with cantools) has a speed within one
    count per window of the truth, with at least MIN_COUNTS counts in the window once the window
    can hold them; one frame per 5 ms."""
    s, bus, t = _tach(lambda t_us: omega * t_us * 1e-6)
    s.run_until(1_500_000)
    frames = bus.frames(0x186)
    assert len(frames) == 300
    checked = 0
    for m in frames[-50:]:
        sig = _dbc_decode(0x186, m.data)
        w = sig["window_ticks"]
        res = 2 * math.pi / CPR / (w * 0.005)           # one count per window [rad/s]
        assert abs(sig["motor_speed"] - omega) <= res * 1.0001 + 1e-6
        assert abs(omega) * w * 0.005 * CPR / (2 * math.pi) >= MIN_COUNTS - 1 or w == 200
        checked += 1
    assert checked == 50


@pytest.mark.parametrize("seed", range(10))
def test_tachometer_window_choice_matches_the_documented_rule_on_random_counts(seed):
    """Random count sequences (rest, crawls, slews, reversals; 3 s): every TACH_STATUS (decoded
    with cantools) carries the window and speed the module doc's rule gives, computed here from
    the whole history of the counts the encoder read (a plain list, newest last): the shortest
    of WINDOWS_TICKS holding at least MIN_COUNTS counts, else the longest the history holds
    (at most TACH_MAX_WINDOW_TICKS); speed = counts over that window."""
    from boards.tachometer import WINDOWS_TICKS

    rng = random.Random(seed)
    per_tick, rate, c = [], 0.0, 0
    for _ in range(620):
        if rng.random() < 0.05:
            rate = rng.choice([0.0, 0.0, 0.2, -0.3, 3.0, -7.0, 40.0, -200.0, 1500.0])
        c += int(round(rate + rng.uniform(-0.5, 0.5))) if rate else 0
        per_tick.append(c)
    s = Scheduler()
    bus = FakeBus()
    read = []

    def counts():
        read.append(per_tick[s.now_us // P.TACH_STATUS_PERIOD_US])
        return read[-1]

    t = Tachometer(s, bus, 6, read_motor_counts=counts, counts_per_rev=CPR)
    t.start()
    nmt_start(t)
    s.run_until(600 * P.TACH_STATUS_PERIOD_US)
    frames = bus.frames(0x186)
    ticks = read[1:]                 # read[0]: the QEI's power-on value, before the first tick
    assert len(frames) >= 590 and len(ticks) >= len(frames)
    for k, m in enumerate(frames):
        hist = ticks[:k + 1][-(P.TACH_MAX_WINDOW_TICKS + 1):]
        n = len(hist) - 1
        want_w, want_d = n, 0
        for w in WINDOWS_TICKS:
            if w > n:
                want_w, want_d = n, (hist[-1] - hist[0]) if n else 0
                break
            want_w, want_d = w, hist[-1] - hist[-1 - w]
            if abs(want_d) >= MIN_COUNTS:
                break
        sig = _dbc_decode(0x186, m.data)
        if want_w == 0:
            assert (sig["window_ticks"], sig["motor_speed"]) == (1, 0), (seed, k)
            continue
        speed = want_d * 2 * math.pi / CPR / (want_w * P.TACH_STATUS_PERIOD_US * 1e-6)
        assert sig["window_ticks"] == want_w, (seed, k, sig["window_ticks"], want_w)
        assert sig["motor_speed"] == pytest.approx(speed, abs=1e-6), (seed, k)


def test_tachometer_counts_follow_the_encoder_and_slow_speeds_use_the_long_window():
    """The counts field is the encoder count since power-on (low 16 bits, wrapping); at the
    motor speed of 15″/s tracking (15 × 360.49 ″/s) the window grows to 1 s."""
    omega = 15 * 360.4886 / ARCSEC_PER_TURN * 2 * math.pi
    s, bus, t = _tach(lambda t_us: 1.0 + omega * t_us * 1e-6)   # starts at 1 rad: QEI zero there
    s.run_until(2_000_000)
    last = P.decode(0x186, bus.frames(0x186)[-1].data)
    true = math.floor((1.0 + omega * 1.995) * CPR / (2 * math.pi)) - math.floor(1.0 * CPR / (2 * math.pi))
    assert last.counts == true & 0xFFFF
    assert last.window_ticks == 200
    assert abs(last.speed_urad_s * 1e-6 - omega) <= 2 * math.pi / CPR / 1.0 + 1e-9


def test_tachometer_silent_before_nmt_start_and_counts_malformed_frames():
    """No TACH_STATUS before NMT start (PRE-OPERATIONAL); a frame on an accepted id that does
    not decode is counted, never raised."""
    s = Scheduler()
    bus = FakeBus()
    t = Tachometer(s, bus, 7, read_motor_counts=lambda: 0, counts_per_rev=CPR)
    t.start()
    s.run_until(50_000)
    assert not bus.frames(0x187)
    bus.inject(P.sdo_request_cob_id(7), b"\x40\x00")                   # SDO request, DLC 2
    s.run_until(60_000)
    assert t.malformed_frames == 1


# -------------------------------------------------------------------------------- auxiliary encoder

BITS, RED = 17, 10.8
WORD = 1 << BITS


def _aux_word(theta_rad: float) -> int:
    """Independent ideal model of the A25S behind a 1:10.8 reduction: the 17-bit word."""
    return math.floor(((theta_rad * RED) % (2 * math.pi)) / (2 * math.pi) * WORD) % WORD


def _position_frame(theta_rad: float, flags: int = 0) -> bytes:
    """A reader's POSITION for axis angle θ (signed, 29-bit two's complement), from docs/protocol.md."""
    c = round(theta_rad / (2 * math.pi) * (1 << 29)) % (1 << 29)
    return bytes([0x02, flags]) + struct.pack("<H", 0) + struct.pack("<I", c)


def _aux(theta_of_t, node=0x0A):
    s = Scheduler()
    bus = FakeBus()
    a = AuxEncoder(s, bus, node, read_aux_word=lambda: _aux_word(theta_of_t(s.now_us)), bits=BITS, reduction=RED)
    a.start()
    nmt_start(a)
    return s, bus, a


def _aux_angle_arcsec(m) -> tuple[int, float]:
    sig = _dbc_decode(m.arbitration_id, m.data)
    return sig["turns_unknown"], sig["aux_counts"] * ARCSEC_PER_TURN / (WORD * RED)


@pytest.mark.parametrize("deg", [50.0, -95.0, 0.2, 109.0])
def test_aux_turn_count_is_seeded_from_the_main_encoder(deg):
    """Before a POSITION arrives the frame says turns_unknown and carries the word alone; after
    its reader's POSITION (0x183 for RA) the multi-turn angle equals the axis angle within one
    count (0.9155″)."""
    theta = math.radians(deg)
    s, bus, a = _aux(lambda t_us: theta)
    s.run_until(30_000)
    unknown, ang = _aux_angle_arcsec(bus.frames(0x18A)[-1])
    assert unknown == 1 and 0 <= ang < ARCSEC_PER_TURN / RED
    bus.inject(0x183, _position_frame(theta))
    s.run_until(60_000)
    unknown, ang = _aux_angle_arcsec(bus.frames(0x18A)[-1])
    assert unknown == 0
    assert abs(ang - deg * 3600) <= ARCSEC_PER_TURN / (WORD * RED) + 1e-6
    assert a.turns_seeded and a.od_read(0x2400, 2) == 1


def test_aux_tracks_turns_through_a_slew_and_ignores_bad_positions():
    """Through a 2°/s slew over several encoder turns the reported angle follows the axis within
    one count; a POSITION flagged INVALID does not seed, and one with a wrong DLC is counted."""
    rate = math.radians(2.0)                        # rad/s
    s, bus, a = _aux(lambda t_us: math.radians(-20) + rate * t_us * 1e-6, node=0x0B)
    s.run_until(20_000)
    bus.inject(0x184, _position_frame(0.0, flags=int(P.PositionFlags.INVALID)))
    bus.inject(0x184, b"\x02\x00")
    s.run_until(30_000)
    assert not a.turns_seeded and a.malformed_frames == 1
    bus.inject(0x184, _position_frame(math.radians(-20) + rate * 0.02))
    s.run_until(40_000_000)                         # 80° of axis: 2.4 encoder turns
    frames = bus.frames(0x18B)
    checked = 0
    for k in range(0, 3900, 37):                    # frame -1-k was read at 40 s - k x 10 ms
        unknown, ang = _aux_angle_arcsec(frames[-1 - k])
        truth = math.degrees(math.radians(-20) + rate * (40.0 - k * 0.01)) * 3600
        assert unknown == 0
        assert abs(ang - truth) <= ARCSEC_PER_TURN / (WORD * RED) + 1e-6, k
        checked += 1
    assert a.turns == math.floor((math.radians(-20) + rate * 40.0) * RED / (2 * math.pi))
    assert checked > 30


def test_aux_reset_forgets_the_turn_count():
    """A processor reset clears the turn count (RAM): turns_unknown until the next POSITION."""
    theta = math.radians(70)
    s, bus, a = _aux(lambda t_us: theta)
    s.run_until(20_000)
    bus.inject(0x183, _position_frame(theta))
    s.run_until(40_000)
    assert a.turns_seeded
    a.reset("watchdog")
    nmt_start(a)
    s.run_until(80_000)
    assert not a.turns_seeded and _aux_angle_arcsec(bus.frames(0x18A)[-1])[0] == 1


# -------------------------------------------------------------------------------- plant sensors

def _plant(overrides=None, seed=0):
    from plant.axis import AxisPlant
    from plant.params import load_parameters
    return AxisPlant(load_parameters(None, overrides).axes["ra"], name="ra", seed=seed)


def test_aux_encoder_error_stays_within_the_paper_accuracy_and_is_seeded():
    """Over random axis angles the A25S word's error at the encoder shaft stays within ±15″
    (paper §3.2) plus one count of quantisation; the same seed repeats the noise, another seed
    does not; ``perfect`` gives the exact floor."""
    rng = random.Random(5)
    p1, p2, p3 = _plant(seed=3), _plant(seed=3), _plant(seed=4)
    perfect = _plant({"perfect": True})
    count_arcsec = ARCSEC_PER_TURN / WORD
    words1, words3 = [], []
    for _ in range(2000):
        th = rng.uniform(-math.pi, math.pi)
        for p in (p1, p2, p3, perfect):
            p.axis_angle_rad = th
        w = p1.aux_encoder_word()
        assert p2.aux_encoder_word() == w
        words1.append(w)
        words3.append(p3.aux_encoder_word())
        phi = (th * RED) % (2 * math.pi)
        assert perfect.aux_encoder_word() == math.floor(phi / (2 * math.pi) * WORD) % WORD
        err = ((w * count_arcsec - phi * 206264.80624709636 + ARCSEC_PER_TURN / 2) % ARCSEC_PER_TURN) - ARCSEC_PER_TURN / 2
        assert -15.0 - count_arcsec <= err <= 15.0
    assert words1 != words3


def test_tach_counts_follow_the_motor_shaft():
    """tach_counts = floor(φ_motor · counts_per_rev / 2π) for each motor (parameter file 4000)."""
    p = _plant()
    p.motor_a_angle_rad, p.motor_b_angle_rad = 10.0, -3.3
    assert p.tach_counts("a") == math.floor(10.0 * 4000 / (2 * math.pi))
    assert p.tach_counts("b") == math.floor(-3.3 * 4000 / (2 * math.pi))
    with pytest.raises(ValueError):
        p.tach_counts("c")


def test_aux_error_model_is_overridable_from_a_scenario(tmp_path):
    """A scenario's plant.overrides set the A25S error terms (here all zero: the exact floor)
    and the tachometer resolution the firmware is built with."""
    from host.network import build_network
    from host.scenario import parse_scenario
    keys = ("once_per_rev_arcsec", "twice_per_rev_arcsec", "noise_arcsec")
    ov = "".join(f"    axes.ra.aux_encoder.{k}: 0.0\n" for k in keys) + "    axes.dec.tachometer.counts_per_rev: 2048\n"
    sc = parse_scenario("name: o\nnetwork: full\nplant:\n  overrides:\n" + ov +
                        "segments:\n  - {name: a, mode: stop, duration_s: 1}\n", str(tmp_path / "s.yaml"))
    tel = build_network(sc)
    try:
        p = tel.plants["ra"]
        for th in (0.1, -1.3, 2.9):
            p.axis_angle_rad = th
            assert p.aux_encoder_word() == math.floor(((th * RED) % (2 * math.pi)) / (2 * math.pi) * WORD) % WORD
        assert tel.boards["dec-tach-1"].counts_per_rev == 2048 and tel.boards["ra-tach-1"].counts_per_rev == 4000
        assert tel.client.tach_counts_per_rev[int(P.NodeId.TACH_DEC_2)] == 2048
    finally:
        tel.close()
