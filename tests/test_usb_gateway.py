"""The USB-HID CAN gateway (PIC18F4550) on the emulated bus, driven through the in-process
``hid.device`` look-alike exactly as a hidapi host program drives the real board."""

import itertools
import struct

import can
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from boards import FocusController, PositionReader
from boards.usb_gateway import RX_QUEUE_FRAMES, UsbGateway
from bus import hid_reports as R
from bus import protocol as p
from bus.network import CanNetwork, frame_bits
from bus.scheduler import Scheduler
from bus.simbus import SimBus
from bus.usb_link import HIDRAW_BUFFER_REPORTS
from host import hid_device

_chan = itertools.count()
VID, PID = 0x04D8, 0x003F


class Rig:
    """Clock, CAN network, a position reader (100 frames/s), the focus board, the gateway on
    the PC's USB, and a passive listener on the bus."""

    def __init__(self, reader=True, focus=True):
        self.s = Scheduler()
        self.net = CanNetwork(self.s, f"gw-test-{next(_chan)}")
        self.boards = []
        if reader:
            self.boards.append(PositionReader(self.s, SimBus(network=self.net), 3, read_position_word=lambda: 12345))
        if focus:
            self.boards.append(FocusController(self.s, SimBus(network=self.net), 5, on_step=lambda d: None))
        self.listener = SimBus(network=self.net)
        self.gw = UsbGateway(self.s, SimBus(network=self.net))
        self.usb = hid_device.SimUsb()
        self.port = self.usb.plug(self.gw)
        for b in self.boards:
            b.start()
        self.gw.start()
        # the boards boot PRE-OPERATIONAL: NMT start (docs/canopen.md) so that they send PDOs
        if self.boards:       # from a node of its own, so the listener sees it like any frame
            SimBus(network=self.net).send(can.Message(
                arbitration_id=p.nmt_cob_id(), is_extended_id=False,
                data=p.encode_nmt(p.NmtCommand.START)))
        self.h = hid_device.device(usb=self.usb)

    def bus_frames(self):
        out = []
        while (m := self.listener.recv()) is not None:
            out.append(m)
        return out

    def close(self):
        self.net.close()


@pytest.fixture
def rig():
    r = Rig()
    yield r
    r.close()


def out_report(frames):
    return [0] + list(R.encode_report(R.KIND_OUT, frames))


def read_all(h, timeout_ms=0):
    reps = []
    while True:
        t, r = h.read_timed(64, timeout_ms)
        if not r:
            return reps
        reps.append((t, R.decode_report(bytes(r), R.KIND_IN)))
        timeout_ms = 0


def status(h):
    r = h.get_feature_report(0, 65)
    assert r[0] == 0 and len(r) == 65
    return R.decode_status(bytes(r[1:]))


def test_ping_round_trip_through_hid(rig):
    """PC → OUT report with a PING → the frame on CAN → boards answer HEARTBEAT → IN reports → PC."""
    h = rig.h
    h.open(VID, PID)
    assert h.get_product_string().startswith("ARIES")
    assert h.send_feature_report([0] + list(R.encode_command(R.CMD_SET_FILTERS, [(0x580, 0x7F0)]))) == 65
    rig.s.run_until(50_000)
    read_all(h)
    rig.bus_frames()
    ping = p.encode_sdo(0x40, 0x1000, 0)          # the health check: SDO upload of 0x1000
    t_write = rig.s.now_us
    assert h.write(out_report([(p.sdo_request_cob_id(3), ping), (p.sdo_request_cob_id(5), ping)])) == 65
    answered = {}
    while len(answered) < 2:
        t, r = h.read_timed(64, 100)
        assert r, "no IN report within 100 ms of the PING"
        rep = R.decode_report(bytes(r), R.KIND_IN)
        for f in rep.frames:
            assert f.arbitration_id in (p.sdo_response_cob_id(3), p.sdo_response_cob_id(5))   # the filter held
            sdo = p.decode_sdo(f.data)
            assert (sdo.command, sdo.index) == (0x43, 0x1000)
            frame_t = rig.gw.boot_us + f.timestamp_us
            assert t_write < frame_t <= t                     # stamped on reception, before the PC took it
            assert t - frame_t <= 1000                       # the next 1 ms poll took it
            answered[f.arbitration_id] = t
    on_bus = [m for m in rig.bus_frames() if m.arbitration_id in (0x603, 0x605)]
    assert len(on_bus) == 2 and all(bytes(m.data) == ping and not m.is_extended_id for m in on_bus)
    assert max(answered.values()) - t_write <= 3000           # write → CAN → answer → PC in ≤ 3 frames
    st_ = status(h)
    assert st_.tx_frames == 2 and st_.out_reports == 1 and st_.out_malformed == 0 and st_.node_id == 0x10


def test_pc_to_can_carries_four_frames_per_report_in_order(rig):
    """Frames of one OUT report reach the bus in slot order; reports queue and go one per ms."""
    h = rig.h
    h.open(VID, PID)
    rig.s.run_until(10_000)
    rig.bus_frames()
    sent = [(0x600 + i, bytes([i] * (i % 9))) for i in range(12)]
    for k in range(3):
        assert h.write(out_report(sent[4 * k:4 * k + 4])) == 65
    rig.s.run_until(rig.s.now_us + 5_000)
    got = [(m.arbitration_id, bytes(m.data)) for m in rig.bus_frames() if m.arbitration_id >= 0x600]
    assert got == sent
    assert rig.port.out_reports == 3 and rig.gw.tx_frames == 12


def test_acceptance_filter_command(rig):
    """SET_FILTERS narrows what reaches the PC; an empty list passes everything again; a bad
    filter command is stalled, counted and leaves the filters as they were."""
    h = rig.h
    h.open(VID, PID)
    pos = p.position_cob_id(3)
    assert h.send_feature_report([0] + list(R.encode_command(R.CMD_SET_FILTERS, [(pos, 0x7FF)]))) == 65
    ids = []
    for _ in range(4):                                         # read every 0.5 s (50 reports)
        rig.s.run_until(rig.s.now_us + 500_000)
        ids += [f.arbitration_id for _, rep in read_all(h) for f in rep.frames]
    assert set(ids) == {pos} and 199 <= len(ids) <= 201          # 100 Hz for 2 s
    bad = bytes([R.CMD_SET_FILTERS, 7]) + bytes(62)
    assert h.send_feature_report([0] + list(bad)) == -1
    st_ = status(h)
    assert st_.filters == 1 and st_.out_malformed == 1 and st_.last_malformed == R.MalformedReason.FILTERS
    assert h.send_feature_report([0] + list(R.encode_command(R.CMD_SET_FILTERS, []))) == 65
    ids = set()
    for _ in range(3):
        rig.s.run_until(rig.s.now_us + 400_000)
        ids |= {f.arbitration_id for _, rep in read_all(h) for f in rep.frames}
    assert {pos, p.heartbeat_cob_id(3), p.heartbeat_cob_id(5), p.focus_status_cob_id()} <= ids


def test_queue_overflow_counts_drops_when_the_pc_does_not_read(rig):
    """A PC that opens and never reads: the host's 64-report buffer fills, then the gateway's
    32-frame queue, then every further frame is dropped, counted and flagged once."""
    h = rig.h
    h.open(VID, PID)
    t0 = rig.s.now_us
    rig.s.run_until(t0 + 2_000_000)
    on_bus = len(rig.bus_frames())
    gw = rig.gw
    # every frame on the bus reaches the gateway (no filter): it is in the host buffer, in the
    # armed IN report, in the queue, or dropped
    assert len(rig.port.received) == HIDRAW_BUFFER_REPORTS
    in_buffer = sum(len(R.decode_report(r, R.KIND_IN).frames) for _, r in rig.port.received)
    armed = len(R.decode_report(gw.usb.in_report, R.KIND_IN).frames)
    assert gw.queue_level == RX_QUEUE_FRAMES and armed >= 1
    assert gw.rx_dropped == on_bus - in_buffer - armed - RX_QUEUE_FRAMES > 100
    assert gw.rx_frames == on_bus - gw.rx_dropped
    st_ = status(h)
    assert st_.rx_dropped == gw.rx_dropped and st_.queue_level == st_.queue_high_water == RX_QUEUE_FRAMES
    assert st_.flags & R.InFlags.RX_OVERFLOW
    reps = []
    t1 = rig.s.now_us
    while rig.s.now_us < t1 + 100_000:                          # now the PC reads for 100 ms
        t, r = h.read_timed(64, 5)
        if r:
            reps.append((t, R.decode_report(bytes(r), R.KIND_IN)))
    flagged = [rep for _, rep in reps if rep.flags & R.InFlags.RX_OVERFLOW]
    assert len(flagged) == 1                                   # one report says "frames were lost here"
    seqs = [rep.seq for _, rep in reps]
    assert all((b - a) % 256 == 1 for a, b in zip(seqs, seqs[1:]))   # no report lost on USB
    got = sum(len(rep.frames) for _, rep in reps)
    assert got >= HIDRAW_BUFFER_REPORTS + 1 + RX_QUEUE_FRAMES     # all kept frames, then live ones
    assert gw.queue_level < RX_QUEUE_FRAMES                        # the PC caught up


def test_status_feature_report(rig):
    """The status report's counters are the gateway's: uptime, node id, queue depth, traffic."""
    h = rig.h
    h.open(VID, PID)
    rig.s.run_until(123_000)
    h.write(out_report([(0x7E0, b"\x01\x02")]))
    rig.s.run_until(200_000)
    n_in = len(read_all(h))
    st_ = status(h)
    gw = rig.gw
    assert (st_.version, st_.node_id, st_.queue_depth, st_.filters) == (R.STATUS_VERSION, 0x10, RX_QUEUE_FRAMES, 0)
    assert st_.uptime_us == rig.s.now_us - gw.boot_us
    assert st_.tx_frames == 1 and st_.out_reports == 1 and st_.in_reports == n_in == rig.port.in_reports
    assert st_.rx_frames == gw.rx_frames > 0 and st_.rx_dropped == 0 and st_.hw_overruns == 0
    assert h.send_feature_report([0] + list(R.encode_command(R.CMD_CLEAR_COUNTERS))) == 65
    st2 = status(h)
    assert st2.tx_frames == st2.rx_frames == st2.in_reports == 0 and st2.uptime_us == st_.uptime_us
    with pytest.raises(OSError):
        h.get_feature_report(1, 65)


@pytest.mark.parametrize("raw,reason", [
    (bytes(63), R.MalformedReason.LENGTH),
    (bytes(65), R.MalformedReason.LENGTH),
    (bytes([0x02, 1]) + bytes(62), R.MalformedReason.KIND),
    (bytes([0x01, 5]) + bytes(62), R.MalformedReason.COUNT),
    (bytes([0x01, 1, 0, 0]) + bytes([0x00, 0x08, 1]) + bytes(57), R.MalformedReason.ID),
    (bytes([0x01, 1, 0, 0]) + bytes([0x23, 0x01, 9]) + bytes(57), R.MalformedReason.DLC),
])
def test_malformed_out_reports_are_counted_never_sent(rig, raw, reason):
    """A malformed OUT report: nothing on CAN, counted with its reason, flagged to the PC, and
    the gateway keeps working."""
    h = rig.h
    h.open(VID, PID)
    rig.s.run_until(20_000)
    read_all(h)
    rig.bus_frames()
    assert h.write([0] + list(raw)) == len(raw) + 1
    rig.s.run_until(rig.s.now_us + 3_000)
    assert not [m for m in rig.bus_frames() if m.arbitration_id in (0x000, 0x123)]
    st_ = status(h)
    assert st_.out_malformed == 1 and st_.last_malformed == reason and st_.tx_frames == 0
    assert any(rep.flags & R.InFlags.OUT_MALFORMED for _, rep in read_all(h, 5))
    h.write(out_report([(0x123, b"\x42")]))
    rig.s.run_until(rig.s.now_us + 3_000)
    assert [bytes(m.data) for m in rig.bus_frames() if m.arbitration_id == 0x123] == [b"\x42"]


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.binary(min_size=0, max_size=80), min_size=1, max_size=8))
def test_random_out_reports_never_crash_the_gateway(raws):
    """Random bytes as OUT reports: every report is either sent or counted, never an exception."""
    r = Rig(reader=False, focus=False)
    try:
        r.h.open(VID, PID)
        for raw in raws:
            assert r.h.write([0] + list(raw)) == len(raw) + 1
        r.s.run_until(20_000)
        gw = r.gw
        good = 0
        for raw in raws:
            try:
                good += len(R.decode_report(raw, R.KIND_OUT).frames)
            except R.ReportError:
                pass
        assert gw.out_reports == len(raws)
        assert gw.tx_frames == good and gw.out_malformed == len(raws) - sum(
            1 for raw in raws if _decodes(raw))
        assert len(r.bus_frames()) == good
    finally:
        r.close()


def _decodes(raw):
    try:
        R.decode_report(raw, R.KIND_OUT)
        return True
    except R.ReportError:
        return False


def test_open_fails_without_a_gateway_and_write_needs_report_number_zero(rig):
    """hidapi behaviour: open of an unknown id raises OSError; report number ≠ 0 → −1."""
    with pytest.raises(OSError):
        hid_device.device(usb=rig.usb).open(0x1234, 0x5678)
    h = rig.h
    h.open(VID, PID)
    assert h.write([1] + [0] * 64) == -1 and "report number" in h.error()
    assert h.read(64, 0) == [] and rig.s.now_us == 0        # timeout 0: returns at once, no time passes
    assert h.read(64, 7) and rig.s.now_us <= 7_000          # the boot heartbeats, within 7 ms


def test_latency_and_throughput_figures(capsys):
    """Measured limits: CAN→PC latency ≤ 1 ms at light load (frames at random instants); PC→CAN
    ≤ 1 ms + one frame time; under saturation at most 4 frames per 1 ms report reach the PC and
    the excess is dropped and counted."""
    import random
    r = Rig(reader=False, focus=False)
    try:
        h = r.h
        h.open(VID, PID)
        src = SimBus(network=r.net)
        rnd = random.Random(12)
        # light load: 200 frames at random instants over 1 s (independent of the USB frame phase)
        for t in sorted(rnd.randrange(1_000, 1_000_000) for _ in range(200)):
            r.s.call_at(t, lambda now: src.send(can.Message(arbitration_id=0x301, data=b"\x01", is_extended_id=False)))
        lat = []
        for _ in range(5):
            r.s.run_until(r.s.now_us + 250_000)
            for t, rep in read_all(h):
                lat += [t - (r.gw.boot_us + f.timestamp_us) for f in rep.frames]
        lat.sort()
        assert len(lat) == 200 and 0 <= lat[0] and lat[-1] <= 1000
        # PC → CAN: write at random instants; time until the frame has been received on the bus
        seen = {}
        r.net.add_tap(lambda m: seen.setdefault(m.data[0], round(m.timestamp * 1e6)) if m.arbitration_id == 0x0F0 else None)
        tx_lat = []
        for k in range(50):
            r.s.run_until(r.s.now_us + rnd.randrange(1, 5_000))
            tw = r.s.now_us
            h.write(out_report([(0x0F0, bytes([k]) + bytes(7))]))
            r.s.run_until(tw + 3_000)
            tx_lat.append(seen[k] - tw)
        tx_lat.sort()
        assert tx_lat[-1] <= 1000 + 150                               # next frame + one 8-byte CAN frame
        # saturation: another node offers 8 frames every ms (about 1 Mbit/s: 8 × ~111 bits)
        t0 = r.s.now_us

        def burst(now):
            for i in range(8):
                src.send(can.Message(arbitration_id=0x300 + i, data=struct.pack("<Q", now), is_extended_id=False))
        ev = r.s.call_every(1000, burst, start_us=t0 + 1000)
        got, reports = 0, 0
        while r.s.now_us < t0 + 100_000:
            tt, rr = h.read_timed(64, 10)
            if rr:
                reports += 1
                got += len(R.decode_report(bytes(rr), R.KIND_IN).frames)
        r.s.cancel(ev)
        ms = (r.s.now_us - t0) / 1000
        assert reports <= ms + 1 and got <= 4 * (ms + 1)
        assert got >= 4 * (ms - 3)                                # the USB side ran at its limit
        assert r.gw.rx_dropped > 0 and r.gw.status().flags & R.InFlags.RX_OVERFLOW
        offered = r.net.stats()["per_id"]
        n_offered = sum(v for k, v in offered.items() if 0x300 <= k <= 0x307)
        with capsys.disabled():
            print(f"\nusb-gateway: CAN->PC latency, 200 frames at random instants: min {lat[0]} us, "
                  f"p50 {lat[100]} us, max {lat[-1]} us; PC->CAN (write -> frame on the bus), 50 writes: "
                  f"min {tx_lat[0]} us, p50 {tx_lat[25]} us, max {tx_lat[-1]} us; saturation: "
                  f"{n_offered} frames offered in {ms:.0f} ms, {got} reached the PC in {reports} IN reports "
                  f"({got / ms:.2f} frames/ms), {r.gw.rx_dropped} dropped and counted")
    finally:
        r.close()


def _idle_skip_run(seed: int, idle_skip: bool):
    """One run of random traffic on a Rig: frames from another node at random instants (bursts
    past the 4-frame report and the 32-frame queue among them), OUT reports written at random
    instants from scheduler callbacks and from outside, a refused feature command, reads at
    random times. Everything the PC and the bus saw, and the counters."""
    import random
    rnd = random.Random(seed)
    r = Rig()
    try:
        if not idle_skip:
            r.port._can_idle = False          # the frame event runs every 1 ms, as it always did
        h = r.h
        h.open(VID, PID)
        src = SimBus(network=r.net)
        wire = []
        r.net.add_tap(lambda m: wire.append((r.s.now_us, m.arbitration_id, bytes(m.data))))
        for _ in range(60):
            t, n = rnd.randrange(1_000, 300_000), rnd.choice((1, 1, 2, 5, 40))
            r.s.call_at(t, lambda now, n=n: [src.send(can.Message(arbitration_id=0x300 + i % 8, data=bytes([i]),
                                                                     is_extended_id=False)) for i in range(n)])
        for _ in range(40):   # single frames whose end on the wire falls on a USB frame boundary
            end = rnd.randrange(2, 300) * 1_000
            r.s.call_at(end - frame_bits(0x3F0, b"\x01"), lambda now: src.send(
                can.Message(arbitration_id=0x3F0, data=b"\x01", is_extended_id=False)))
        for k in range(30):   # OUT reports from host-priority callbacks (some at frame boundaries)
            t = rnd.randrange(1_000, 300_000) // rnd.choice((1, 1000)) * rnd.choice((1, 1000))
            r.s.call_at(min(t, 299_000), lambda now, k=k: h.write(out_report([(0x0F0, bytes([k]))])), priority=40)
        got = []
        while r.s.now_us < 300_000:
            r.s.run_until(min(300_000, r.s.now_us + rnd.choice((1, 999, 1_000, 2_500, 7_000))))
            if rnd.random() < 0.2:
                h.write(out_report([(0x0F1, bytes([rnd.randrange(256)]))]))
            if rnd.random() < 0.05:
                assert h.send_feature_report([0, 0x7F] + [0] * 63) == -1      # refused: flag next report
            if rnd.random() < 0.7:
                while (tr := h.read_timed(64, 0))[1]:
                    got.append((tr[0], bytes(tr[1])))
        port = r.port
        counters = port.counters()
        assert (counters.pop("idle_frames") > 10_000 // 1_000) == idle_skip   # the skip did happen
        return (got, wire, r.gw.status()._asdict() | {"uptime_us": None}, counters,
                r.gw.usb.in_naks, r.gw.usb.out_naks, port.out_wait_sum_us)
    finally:
        r.close()


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_idle_frames_skipped_change_nothing(seed):
    """The port's idle-frame skip (bus/usb_link.py) gives the same IN reports at the same times,
    the same frames on the bus and the same counters as a frame event that runs every 1 ms."""
    fast, always = _idle_skip_run(seed, True), _idle_skip_run(seed, False)
    assert fast == always
    assert len(fast[0]) > 50 and fast[2]["rx_dropped"] > 0 and fast[2]["out_malformed"] > 0
    assert sum(1 for t, i, _ in fast[1] if i == 0x3F0 and t % 1_000 == 0) >= 10    # boundary arrivals


def test_frames_the_report_cannot_carry_are_counted_not_forwarded(rig):
    """A frame of more than 8 data bytes, a remote and an extended frame handed to the gateway's
    receive path (as host/fuzz.py does) are counted in rx_unsupported; the IN reports stay valid."""
    rig.h.open(VID, PID)
    rig.s.run_until(5_000)
    read_all(rig.h)
    n = rig.gw.rx_unsupported
    for msg in (can.Message(arbitration_id=0x123, data=bytes(35), is_extended_id=False),
                can.Message(arbitration_id=0x123, is_remote_frame=True, is_extended_id=False),
                can.Message(arbitration_id=0x12345, data=b"\1", is_extended_id=True)):
        rig.gw.can.on_rx(msg)
    rig.s.run_until(20_000)
    reps = read_all(rig.h)
    assert rig.gw.rx_unsupported == n + 3 and reps
    assert all(f.arbitration_id != 0x123 and len(f.data) <= 8 for _, rep in reps for f in rep.frames)
