"""Specification of issue 12's axis velocity readers (nodes 0x0F, 0x11): the AXIS_VELOCITY frame
as docs/protocol.md lays it out (decoded with cantools from bus/schmidt.dbc, not with the
project's codec), the firmware against an independent encoder generator, and the full network."""

from __future__ import annotations

import math
import random
import struct

import pytest

from boards.velocity_reader import MIN_COUNTS, AxisVelocityReader
from bus import protocol as P
from bus.scheduler import Scheduler
from boards_fakes import FakeBus, nmt_start

#: §2.2: 4.608 million ppr Gurley encoder through the 735:30 friction roller.
CPR = 4_608_000 * 735 // 30
ARCSEC_PER_COUNT = 1_296_000.0 / CPR


def _dbc(cob_id: int, data: bytes) -> dict:
    return P.load_dbc().get_message_by_frame_id(cob_id).decode(bytes(data), decode_choices=False)


def test_axis_velocity_layout_as_documented():
    """AXIS_VELOCITY 0x18F (RA) / 0x191 (DEC): b0 device type 0x09, b1 window in 10 ms ticks,
    b2-3 count u16 LE (wraps), b4-7 axis rate i32 LE in milli-arcsec/s; the DBC scales to ″/s."""
    assert [P.axis_velocity_cob_id(n) for n in P.VEL_NODES] == [0x18F, 0x191]
    data = P.encode_axis_velocity(20, 0x1ABCD, -15_041)
    assert data == bytes([0x09, 20]) + struct.pack("<H", 0xABCD) + struct.pack("<i", -15_041)
    sig = _dbc(0x191, data)
    assert sig["device_type"] == 9 and sig["window_ticks"] == 20 and sig["counts"] == 0xABCD
    assert sig["axis_rate"] == pytest.approx(-15.041)
    assert P.frame_name(0x18F) == "AXIS_VELOCITY_RA" and P.frame_name(0x191) == "AXIS_VELOCITY_DEC"
    from bus.errors import MalformedFrame
    for bad in (data[:7], bytes([0x04]) + data[1:], bytes([0x09, 0]) + data[2:], bytes([0x09, 101]) + data[2:]):
        with pytest.raises(MalformedFrame):
            P.decode(0x18F, bad)


def _reader(theta_of_t, node=0x0F):
    """A velocity reader whose encoder follows ``theta_of_t(t_us)`` [arcsec of axis angle]: the
    count is the exact floor of angle / resolution (an ideal encoder, written here)."""
    s = Scheduler()
    bus = FakeBus()
    r = AxisVelocityReader(s, bus, node, qei_counts_per_rev=CPR,
                           read_qei_counts=lambda: math.floor(theta_of_t(s.now_us) / ARCSEC_PER_COUNT))
    r.start()
    nmt_start(r)
    return s, bus, r


@pytest.mark.parametrize("rate", [15.041, -15.041, 100.0, 7199.748, -1.5])
def test_rate_within_one_count_per_window_of_the_truth(rate):
    """At a constant axis rate every AXIS_VELOCITY after the first second (decoded with cantools)
    is within one count per window of the true rate, its window holds ≥ MIN_COUNTS counts unless
    it is the longest (1 s), and one frame comes every 10 ms."""
    phase = random.Random(int(rate * 1000)).uniform(0, 1000)
    s, bus, r = _reader(lambda t_us: phase + rate * t_us * 1e-6)
    s.run_until(2_000_000)
    frames = bus.frames(0x18F)
    assert len(frames) == 200
    for m in frames[-100:]:
        sig = _dbc(0x18F, m.data)
        w = sig["window_ticks"]
        one_count = ARCSEC_PER_COUNT / (w * 0.010)
        assert abs(sig["axis_rate"] - rate) <= one_count + 0.001 + 1e-9
        assert abs(rate) * w * 0.010 / ARCSEC_PER_COUNT >= MIN_COUNTS - 1 or w == 100


def test_tracking_uses_a_window_that_resolves_it_and_slew_the_shortest():
    """15″/s (1306 counts/s) needs ≥ 256 counts: the 200 ms window; the 2°/s slew: 20 ms."""
    s, bus, r = _reader(lambda t_us: 15.041 * t_us * 1e-6)
    s.run_until(1_000_000)
    assert _dbc(0x18F, bus.frames(0x18F)[-1].data)["window_ticks"] == 20
    sampled = []
    s, bus, r = _reader(lambda t_us: sampled.append(t_us) or 7200.0 * t_us * 1e-6, node=0x11)
    s.run_until(1_000_000)
    last = _dbc(0x191, bus.frames(0x191)[-1].data)
    assert last["window_ticks"] == 2
    # the 16-bit count field wraps many times at slew (6272 counts per 10 ms): the low 16 bits of
    # the count at the last sample since power-on (the first sample)
    t0, t1 = sampled[0], sampled[-1]
    assert last["counts"] == (math.floor(7200.0 * t1 * 1e-6 / ARCSEC_PER_COUNT)
                              - math.floor(7200.0 * t0 * 1e-6 / ARCSEC_PER_COUNT)) & 0xFFFF


def test_silent_before_nmt_start_counts_malformed_frames_and_refuses_rs232():
    s = Scheduler()
    bus = FakeBus()
    r = AxisVelocityReader(s, bus, 0x11, read_qei_counts=lambda: 0, qei_counts_per_rev=CPR)
    r.start()
    s.run_until(50_000)
    assert not bus.frames(0x191)
    bus.inject(P.sdo_request_cob_id(0x11), b"\x40\x00")
    s.run_until(60_000)
    assert r.malformed_frames == 1
    with pytest.raises(ValueError, match="RS232"):
        AxisVelocityReader(Scheduler(), FakeBus(), 0x0F, read_qei_counts=lambda: 0, qei_counts_per_rev=CPR,
                           serial_port=object())


def test_full_network_has_over_sixteen_boards_and_logs_the_velocity_node(tmp_path):
    """``network: full`` is Fig. 5's "over sixteen" boards (17); the velocity readers' rate is in
    sensor.log and agrees with the axis rate the plant ran while the RA axis tracks."""
    from boards.registry import NETWORKS
    from host.runner import run_scenario
    from host.scenario import parse_scenario
    assert len(NETWORKS["full"]) >= 17 and {"ra-velocity", "dec-velocity"} <= set(NETWORKS["full"])
    sc = parse_scenario("""
name: vel
network: [ra-axis, dec-axis, ra-reader, dec-reader, ra-velocity, dec-velocity]
segments:
  - {name: track, axis: ra, mode: track, duration_s: 6}
""", str(tmp_path / "s.yaml"))
    res = run_scenario(sc, tmp_path, plots=False)
    lines = (tmp_path / "sensor.log").read_text().splitlines()
    header = next(ln for ln in lines if ln.startswith("#") and "ra_velocity_node_arcsec_s" in ln).lstrip("# ").split()
    rows = [ln.split() for ln in lines if not ln.startswith("#")]
    col = header.index("ra_velocity_node_arcsec_s")
    # the axis breaks away from static friction at ≈ 3 s (low preload); from 4 s it tracks
    late = [float(r[col]) for r in rows if float(r[0]) > 4.0]
    assert late and all(abs(v - 15.041) < 0.5 for v in late), late[:5]
    dec = [float(r[header.index("dec_velocity_node_arcsec_s")]) for r in rows if float(r[0]) > 4.0]
    assert dec and all(abs(v) < 0.1 for v in dec)
    assert res.report["boards"]["ra-velocity"]["window_ticks"] == 20
