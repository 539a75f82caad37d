"""Specification of bus.serial_link: RS232 byte timing in simulated time, pyserial-like ends."""

import serial

from bus.scheduler import Scheduler
from bus.serial_link import SerialLink


def send_packet(port, samples):
    """Firmware-side helper written against the pyserial API."""
    return port.write(b"PKT" + bytes(samples) + b"\n")


def read_packet(port):
    """Host-side helper written against the pyserial API."""
    line = port.read_until(b"\n")
    return line if line.endswith(b"\n") else None


def test_byte_timing_8n1():
    """At 9600 baud 8N1 each byte takes 10/9600 s; byte i is readable at ceil((i+1)·1041.67 µs)."""
    s = Scheduler()
    link = SerialLink(s, baud=9600)
    link.a.write(b"abc")
    assert link.b.in_waiting == 0
    s.run_until(1041)
    assert link.b.in_waiting == 0
    s.run_until(1042)
    assert link.b.read(10) == b"a"
    s.run_until(3125)
    assert link.b.read(10) == b"bc"
    assert link.transfer_time_us(3) == 3125


def test_writes_queue_behind_bytes_on_the_wire():
    """A second write waits until the transmitter has shifted out the first."""
    s = Scheduler()
    link = SerialLink(s, baud=115_200)
    link.a.write(bytes(10))
    s.run_until(100)
    link.a.write(b"\xff")
    s.run_until(link.transfer_time_us(10))
    assert link.b.read(100) == bytes(10)
    s.run_until(link.transfer_time_us(10) + link.transfer_time_us(1))   # bursts start on whole µs
    assert link.b.read(100) == b"\xff"


def test_full_duplex_and_out_waiting():
    """Both directions run independently; out_waiting counts bytes not yet received."""
    s = Scheduler()
    link = SerialLink(s, baud=115_200)
    link.a.write(b"ping")
    link.b.write(b"pong")
    assert link.a.out_waiting == 4
    s.run_until(10_000)
    assert link.b.read_all() == b"ping" and link.a.read_all() == b"pong"
    assert link.a.out_waiting == 0


def test_packet_of_25_samples_every_250_ms_fits():
    """A 25-sample telemetry packet (paper §3.4) arrives within its 250 ms period at 115200."""
    s = Scheduler()
    link = SerialLink(s, baud=115_200)
    got = []
    link.b.set_rx_callback(lambda: got.append((s.now_us, read_packet(link.b))))
    s.call_every(250_000, lambda now: send_packet(link.a, [0x55] * 200), start_us=0)
    s.run_until(1_000_000)
    nbytes = 3 + 200 + 1
    assert [t for t, _ in got] == [k * 250_000 + link.transfer_time_us(nbytes) for k in range(4)]
    assert all(p == b"PKT" + bytes([0x55] * 200) + b"\n" for _, p in got)


def test_same_helpers_work_on_pyserial_loop_url():
    """The pyserial-API helpers behave the same on serial_for_url('loop://') and on a SerialEnd."""
    loop = serial.serial_for_url("loop://", timeout=0.05)
    send_packet(loop, [1, 2, 3])
    assert read_packet(loop) == b"PKT\x01\x02\x03\n"
    s = Scheduler()
    link = SerialLink(s)
    send_packet(link.a, [1, 2, 3])
    assert read_packet(link.b) is None          # nothing has arrived at t = 0
    s.run_until(link.transfer_time_us(7))
    assert read_packet(link.b) == b"PKT\x01\x02\x03\n"


def test_partial_line_is_returned_like_pyserial_timeout_zero():
    """read_until returns what has arrived when the terminator has not (timeout-0 semantics)."""
    s = Scheduler()
    link = SerialLink(s, baud=9600)
    link.a.write(b"ab\n")
    s.run_until(link.transfer_time_us(2))
    assert link.b.read_until(b"\n") == b"ab"
    s.run_until(link.transfer_time_us(3))
    assert link.b.read_until(b"\n") == b"\n"
