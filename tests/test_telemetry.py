"""Specification of the RS232 telemetry packets (bus.telemetry), the host's packet receiver
(host.rs232.TelemetryPort) and the boards' telemetry firmware on a real pyserial object."""

import pytest
import serial
from hypothesis import given, settings
from hypothesis import strategies as st

from boards.axis_controller import AxisController
from boards.focus_controller import FocusController
from boards.position_reader import PositionReader
from bus import protocol as p
from bus import telemetry as T
from bus.errors import MalformedFrame
from bus.scheduler import Scheduler
from bus.serial_link import SerialLink
from host.rs232 import Rs232Hub, TelemetryPort
from boards_fakes import FakeBus, ToyAxis, nmt_start

_RANGES = {"b": (-128, 127), "B": (0, 255), "h": (-32768, 32767), "H": (0, 65535),
           "i": (-(1 << 31), (1 << 31) - 1), "I": (0, (1 << 32) - 1)}
NODE_OF_DEVICE = {T.DEVICE_AXIS: 1, T.DEVICE_READER: 3, T.DEVICE_FOCUS: 5}


def samples_strategy(device):
    one = st.tuples(*(st.integers(*_RANGES[code]) for _, code, _ in T.SAMPLE_FIELDS[device]))
    return st.lists(one, min_size=T.SAMPLES_PER_PACKET, max_size=T.SAMPLES_PER_PACKET)


@st.composite
def packets(draw, device=None):
    """(device, node, seq, t0_us, samples, encoded bytes)."""
    device = draw(st.sampled_from(sorted(T.SAMPLE_FIELDS))) if device is None else device
    node = NODE_OF_DEVICE[device]
    seq = draw(st.integers(0, 0xFFFF))
    t0 = draw(st.integers(0, (1 << 32) - 1))
    samples = draw(samples_strategy(device))
    flat = [v for s in samples for v in s]
    return device, node, seq, t0, samples, T.encode_packet(device, node, seq, t0, flat)


class Sink:
    def __init__(self):
        self.got = []

    def __call__(self, port, seq, t0, period, buf, offset):
        flat = port.unpack(buf, offset)
        k = len(T.SAMPLE_FIELDS[port.device_type])
        self.got.append((seq, t0, [flat[j:j + k] for j in range(0, len(flat), k)]))


def receiver(node=1, baud=115_200):
    sink = Sink()
    return TelemetryPort(None, "b", node, baud, lambda: 0, sink), sink


def test_packet_sizes_and_wire_time_fit_the_250_ms_interval():
    """Axis 566, reader 141, focus 291 bytes; at 115 200 baud 8N1 the largest takes 49.1 ms
    (20 % of 250 ms); at 19 200 baud it would not fit (295 ms)."""
    assert [T.packet_size(d) for d in (1, 2, 3)] == [14 + 25 * 22 + 2, 14 + 25 * 5 + 2, 14 + 25 * 11 + 2]
    assert T.wire_time_us(566, 115_200) == 49_132
    assert T.wire_time_us(566, 38_400) < T.PACKET_PERIOD_US < T.wire_time_us(566, 19_200)


@settings(max_examples=150, deadline=None)
@given(packets())
def test_encode_decode_round_trip(pk):
    """Every field of every sample survives encode → decode, for all three device types."""
    device, node, seq, t0, samples, data = pk
    assert len(data) == T.packet_size(device)
    d = T.decode_packet(data, node)
    assert (d.device_type, d.node, d.seq, d.t0_us, d.period_us) == (device, node, seq, t0, 10_000)
    assert [list(s) for s in d.samples] == [list(s) for s in samples]


def test_crc_is_ccitt_false_over_header_and_payload():
    """The last two bytes are CRC-16/CCITT-FALSE (check value 0x29B1 for b'123456789') of bytes
    2..end−2, little-endian."""
    assert T.crc16(b"123456789") == 0x29B1
    data = T.encode_packet(2, 3, 7, 123, [5, 1] * 25)
    assert int.from_bytes(data[-2:], "little") == T.crc16(data[2:-2])
    assert data[:2] == b"\xA5\x5A" and data[2:6] == bytes([1, 2, 3, 25])


@settings(max_examples=200, deadline=None)
@given(st.data())
def test_a_flipped_byte_is_detected_and_counted(data):
    """One corrupted byte anywhere in a packet: that packet is rejected and counted (CRC or header
    error; for a sync byte, skipped bytes), the packets around it decode, the gap is counted."""
    device = data.draw(st.sampled_from(sorted(T.SAMPLE_FIELDS)))
    node = NODE_OF_DEVICE[device]
    flat = [v for s in data.draw(samples_strategy(device)) for v in s]
    pk = [T.encode_packet(device, node, seq, seq * 250_000, flat) for seq in range(3)]
    k = data.draw(st.integers(0, len(pk[1]) - 1))
    x = data.draw(st.integers(1, 255))
    bad = bytearray(pk[1])
    bad[k] ^= x
    tp, sink = receiver(node)
    assert tp.feed(pk[0] + bytes(bad) + pk[2]) == 2
    assert [g[0] for g in sink.got] == [0, 2]
    assert tp.seq_gaps == 1
    if k >= 2:
        assert tp.crc_errors + tp.header_errors >= 1
    assert tp.discarded_bytes >= 2
    with pytest.raises(MalformedFrame):
        T.decode_packet(bytes(bad), node)


@settings(max_examples=100, deadline=None)
@given(garbage=st.binary(max_size=400), chunks=st.lists(st.integers(1, 700), min_size=1, max_size=30),
       pk=packets(device=T.DEVICE_AXIS))
def test_resync_after_garbage_in_any_chunking(garbage, chunks, pk):
    """Garbage before and between packets, delivered in arbitrary pieces, never hides a good packet
    and never raises; the skipped bytes are counted."""
    device, node, seq, t0, samples, data = pk
    stream = garbage + data + garbage[: len(garbage) // 2] + data
    tp, sink = receiver(node)
    i = 0
    for c in chunks * (len(stream) // sum(chunks) + 1):
        tp.feed(stream[i:i + c])
        i += c
        if i >= len(stream):
            break
    assert [g[0] for g in sink.got][-2:] == [seq, seq]
    assert len(sink.got) == 2
    assert [list(s) for s in sink.got[0][2]] == [list(s) for s in samples]
    assert tp.discarded_bytes >= len(garbage) - 1


def test_truncated_packet_counted_and_next_packet_recovered():
    """A packet cut short (board reset mid-transmission) fails its CRC once the next packet's
    bytes arrive; the next packet itself is decoded."""
    flat = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10] * 25
    a = T.encode_packet(1, 1, 0, 0, flat)
    b = T.encode_packet(1, 1, 1, 250_000, flat)
    tp, sink = receiver(1)
    assert tp.feed(a[:300]) == 0 and tp.crc_errors == 0     # waits for the rest
    assert tp.feed(b) == 1
    assert tp.crc_errors == 1 and [g[0] for g in sink.got] == [1]


def test_header_for_another_node_is_rejected():
    """A port knows its board: a packet claiming another node is a header error, not data."""
    tp, sink = receiver(2)
    tp.feed(T.encode_packet(1, 1, 0, 0, [0] * 250))
    assert sink.got == [] and tp.header_errors == 1


# --------------------------------------------------------------------------------------------
# boards on a real pyserial object
# --------------------------------------------------------------------------------------------


def drain_loop(port, tp):
    """Host side against the pyserial API: read what is waiting and parse it."""
    tp.feed(port.read(port.in_waiting))


def test_axis_controller_telemetry_on_pyserial_loop():
    """The axis firmware writes through a pyserial ``loop://`` port unchanged: one 566-byte packet
    per 250 ms, 25 samples 10 ms apart from t = 10 ms, whose QEI counts and effort equal the
    AXIS_STATUS frames sent at the same instants."""
    s = Scheduler()
    bus = FakeBus()
    plant = ToyAxis(s)
    port = serial.serial_for_url("loop://", timeout=0)
    ax = AxisController(s, bus, 1, read_qei_counts=plant.qei_counts, on_duties=plant.set_duties,
                        serial_port=port)
    ax.start()
    nmt_start(ax)
    bus.inject(p.axis_command_cob_id(1), p.encode_axis_command(p.AxisCommand.SET, 1, 0))
    tp, sink = receiver(1)
    for k in range(1, 5):
        s.run_until(k * 250_000)
        assert port.in_waiting == 566
        drain_loop(port, tp)
    assert tp.packets == 4 and tp.crc_errors == tp.header_errors == tp.discarded_bytes == 0
    assert [g[0] for g in sink.got] == [0, 1, 2, 3]
    assert [g[1] for g in sink.got] == [10_000, 260_000, 510_000, 760_000]
    samples = [smp for g in sink.got for smp in g[2]]
    status = [p.decode_axis_status(m.data) for m in bus.frames(p.axis_status_cob_id(1))]
    assert len(samples) == 100 and len(status) >= 100
    for smp, stf in zip(samples, status):
        u_q15, pdc_a, pdc_b, qei, delta, adc_a, adc_b, sp_m, mode, flags = smp
        assert (qei & 0xFFFFFF, u_q15, mode, flags) == (stf.qei_counts, stf.u_q15, stf.mode, stf.flags)
        assert sp_m == 600_000
    assert samples[-1][3] > 0 and samples[-1][1] > 0       # moving forward, motor A driven


def test_reader_and_focus_telemetry_on_pyserial_loop():
    """Reader and focus firmware on ``loop://``: the reader's samples carry the position word plus
    offset; the focus samples carry the half-step counter and the encoder counts."""
    s = Scheduler()
    rport = serial.serial_for_url("loop://", timeout=0)
    fport = serial.serial_for_url("loop://", timeout=0)
    rd = PositionReader(s, FakeBus(), 3, read_position_word=lambda: 1000, offset_counts=5,
                        serial_port=rport)
    enc = {"n": 0}
    fbus = FakeBus()
    fc = FocusController(s, fbus, 5, on_step=lambda d: enc.update(n=enc["n"] + 5 * d),
                         read_encoder_counts=lambda: enc["n"], serial_port=fport)
    rd.start()
    nmt_start(rd)
    fc.start()
    nmt_start(fc)
    fbus.inject(p.focus_command_cob_id(), p.encode_focus_command(p.FocusCommand.STEP, 40))
    s.run_until(250_000)
    tr, rsink = receiver(3)
    tf, fsink = receiver(5)
    drain_loop(rport, tr)
    drain_loop(fport, tf)
    assert tr.packets == tf.packets == 1
    assert all(smp == (1005, 0) for smp in rsink.got[0][2])
    last = fsink.got[0][2][-1]
    assert last[:2] == (40, 200) and last[3] == 0       # 40 half-steps, 200 counts, none missed


def test_board_reset_truncates_packet_and_hub_recovers():
    """A board reset mid-packet aborts the transmission (UART reset): the hub counts a CRC error,
    sees the restart (sequence back to 0) and keeps decoding; its time base stays the host's."""
    s = Scheduler()
    bus = FakeBus()
    plant = ToyAxis(s)
    link = SerialLink(s, baud=115_200)
    ax = AxisController(s, bus, 1, read_qei_counts=plant.qei_counts, on_duties=plant.set_duties,
                        serial_port=link.a)
    hub = Rs232Hub(s, 115_200)
    tp = hub.add_port(link.b, "ra-axis", 1)
    ax.start()
    nmt_start(ax)
    s.run_until(500_000 + 20_000)        # second packet is 20 ms into its 49 ms on the wire
    ax.reset("software")
    s.run_until(1_500_000)
    assert tp.crc_errors == 1 and tp.restarts == 1
    assert tp.packets == 1 + 3           # seq 0 before, then 0, 1, 2 after the reboot at 0.52 s
    assert tp.offset_us == 520_000       # board time 0 = host time 0.52 s, exact


def test_no_port_no_sampling():
    """Without a serial port the firmware records nothing (no cost when RS232 is off)."""
    s = Scheduler()
    plant = ToyAxis(s)
    ax = AxisController(s, FakeBus(), 1, read_qei_counts=plant.qei_counts, on_duties=plant.set_duties)
    ax.start()
    nmt_start(ax)
    s.run_until(300_000)
    assert ax.uart is None and ax._tlm_values == [] and ax.telemetry_seq == 0
