"""Specification of bus.simbus: the python-can interface "schmidt-sim" in simulated time."""

import can
import pytest

import bus  # noqa: F401  (registers the interface)
from bus.errors import BusError
from bus.network import CanNetwork, frame_bits
from bus.scheduler import PRIO_ISR, Scheduler
from bus.simbus import SimBus


@pytest.fixture
def sched():
    return Scheduler()


@pytest.fixture
def channel(sched, request):
    name = f"sim-{request.node.name}"
    network = CanNetwork(sched, name)
    yield name
    network.close()


def frame(aid=0x181, data=bytes(8)):
    return can.Message(arbitration_id=aid, data=data, is_extended_id=False)


def test_can_bus_factory_creates_simbus(channel):
    """can.Bus(interface="schmidt-sim", channel=...) works after `import bus`."""
    b = can.Bus(interface="schmidt-sim", channel=channel)
    assert isinstance(b, SimBus) and isinstance(b, can.BusABC)
    assert "schmidt-sim" in can.interfaces.BACKENDS
    assert b.protocol == can.CanProtocol.CAN_20
    b.shutdown()


def test_send_and_receive_through_python_can_api(sched, channel):
    """A frame sent on one bus is received on the others, not on the sender."""
    a = can.Bus(interface="schmidt-sim", channel=channel)
    b = can.Bus(interface="schmidt-sim", channel=channel)
    c = can.Bus(interface="schmidt-sim", channel=channel)
    sent = frame(0x201, bytes([0x10, 6, 1, 0, 1, 2, 3, 4]))
    a.send(sent)
    sched.run_until(1_000)
    for rx in (b, c):
        got = rx.recv(timeout=0)
        assert got.equals(sent, timestamp_delta=None, check_channel=False)
        assert got.is_rx and not got.is_extended_id and got.channel == channel
    assert a.recv(timeout=0) is None


def test_recv_returns_none_immediately_even_without_timeout(channel):
    """recv() never blocks in simulated time, even with timeout=None."""
    b = SimBus(channel)
    assert b.recv() is None and b.recv(timeout=None) is None and b.recv(1.0) is None
    assert b._recv_internal(timeout=None) == (None, False)


def test_sender_may_reuse_its_message_object(sched, channel):
    """The frame's data is captured at send(): mutating the Message afterwards has no effect."""
    a, b = SimBus(channel), SimBus(channel)
    m = frame(0x181, bytearray(8))
    a.send(m)
    m.data[0] = 0xFF
    sched.run_until(1_000)
    assert b.recv().data[0] == 0


def test_each_receiver_gets_its_own_equal_message(sched, channel):
    """Every receiver reads an equal Message (identifier, data, end-of-frame timestamp, is_rx,
    channel); each is its own object, so one program mutating its copy cannot change what
    another reads (the network queues an RxFrame and SimBus builds the Message on reading)."""
    a, b, c = SimBus(channel), SimBus(channel), SimBus(channel)
    a.send(frame())
    sched.run_until(1_000)
    mb, mc = b.recv(), c.recv()
    assert mb is not mc and isinstance(mb, can.Message) and isinstance(mc, can.Message)
    assert mb.equals(mc) and mb.is_rx and mb.channel == channel and not mb.is_extended_id
    mb.data[0] ^= 0xFF
    assert mc.data == frame().data


def test_drain_rx_frames_matches_recv(sched, channel):
    """``drain_rx_frames`` (the boards' receive path) gives the same frames as ``recv``."""
    a, b, c = SimBus(channel), SimBus(channel), SimBus(channel)
    for i in range(3):
        a.send(can.Message(arbitration_id=0x180 + i, data=bytes([i] * (i + 1)), is_extended_id=False))
    sched.run_until(2_000)
    frames = b.drain_rx_frames()
    msgs = list(iter(c.recv, None))
    assert [(f.arbitration_id, f.data, f.t_us / 1e6) for f in frames] == \
        [(m.arbitration_id, bytes(m.data), m.timestamp) for m in msgs]
    assert b.drain_rx_frames() == [] and b.recv() is None


def test_can_filters_are_acceptance_filters(sched, channel):
    """Filtered-out frames are neither queued nor raise the rx callback."""
    a = SimBus(channel)
    b = SimBus(channel, can_filters=[{"can_id": 0x200, "can_mask": 0x780, "extended": False}])
    calls = []
    b.set_rx_callback(lambda: calls.append(1))
    a.send(frame(0x181))
    a.send(frame(0x201))
    sched.run_until(1_000)
    assert [m.arbitration_id for m in iter(b.recv, None)] == [0x201]
    assert calls == [1]


def test_rx_callback_runs_through_scheduler_after_delivery(sched, channel):
    """The rx callback (receive interrupt) runs at the delivery µs, and can read the frame."""
    a, b = SimBus(channel), SimBus(channel, name="ra-axis")
    seen = []
    b.set_rx_callback(lambda: seen.append((sched.now_us, b.recv().arbitration_id)))
    sched.call_at(100, lambda now: a.send(frame(0x201)), PRIO_ISR)
    sched.run_until(10_000)
    assert seen == [(100 + frame_bits(0x201, bytes(8)), 0x201)]


def test_rx_callback_changed_by_an_earlier_interrupt_of_the_same_frame(sched, channel):
    """Receive interrupts of one frame run in attach order, and each runs the callback its bus
    has at that moment: one switched off, or replaced, by an earlier receiver's interrupt of the
    same frame is not the one called (the network's table caches the callbacks, session 17)."""
    a, b, c, d = (SimBus(channel, name=n) for n in "abcd")
    calls = []
    c.set_rx_callback(lambda: calls.append("c"))
    d.set_rx_callback(lambda: calls.append("d-old"))

    def b_isr():
        calls.append("b")
        c.set_rx_callback(None)                        # e.g. a board reset by b's handler
        d.set_rx_callback(lambda: calls.append("d-new"))

    b.set_rx_callback(b_isr)
    a.send(frame(0x201))
    sched.run_until(1_000)
    assert calls == ["b", "d-new"]
    calls.clear()
    a.send(frame(0x202))                               # the table is rebuilt with the new ones
    sched.run_until(2_000)
    assert calls == ["b", "d-new"]


def test_receive_own_messages(sched, channel):
    """receive_own_messages=True echoes the bus's own frames (is_rx False)."""
    a = SimBus(channel, receive_own_messages=True)
    a.send(frame())
    sched.run_until(1_000)
    echo = a.recv()
    assert echo is not None and echo.is_rx is False


def test_shutdown_detaches(sched, channel):
    """After shutdown a bus receives nothing and cannot send."""
    a, b = SimBus(channel), SimBus(channel)
    b.shutdown()
    a.send(frame())
    sched.run_until(1_000)
    assert b.recv() is None
    with pytest.raises(BusError):
        b.send(frame())
    b.shutdown()  # idempotent


def test_rx_queue_overrun_drops_oldest(sched, channel):
    """A bounded receive buffer drops the oldest frame and counts the overrun."""
    a, b = SimBus(channel), SimBus(channel, rx_queue_size=2)
    for aid in (0x101, 0x102, 0x103):
        a.send(frame(aid))
    sched.run_until(1_000)
    assert [m.arbitration_id for m in iter(b.recv, None)] == [0x102, 0x103]
    assert b.rx_overruns == 1


def test_unknown_channel_fails_clearly():
    """can.Bus on a channel without a CanNetwork raises BusError naming it."""
    with pytest.raises(BusError, match="no-such-channel"):
        can.Bus(interface="schmidt-sim", channel="no-such-channel")


def test_explicit_network_argument(sched, request):
    """SimBus(network=...) bypasses the registry."""
    net = CanNetwork(sched, f"explicit-{request.node.name}")
    a, b = SimBus(network=net), SimBus(network=net)
    a.send(frame())
    sched.run_until(1_000)
    assert b.recv() is not None
    net.close()


def test_filters_changed_while_running_apply_to_the_next_frame(sched, channel):
    """The network's identifier -> receivers table follows set_filters, attach and detach:
    a bus that changes its filters between frames gets exactly what the new filters pass."""
    a = SimBus(channel)
    b = SimBus(channel, can_filters=[{"can_id": 0x181, "can_mask": 0x7FF, "extended": False}])
    got = []
    b.set_rx_callback(lambda: got.append(b.recv().arbitration_id))
    for aid in (0x181, 0x182):
        a.send(frame(aid))
    sched.run_until(1_000)
    b.set_filters([{"can_id": 0x180, "can_mask": 0x7F0, "extended": False}])   # a mask filter
    for aid in (0x181, 0x182, 0x201):
        a.send(frame(aid))
    sched.run_until(2_000)
    b.set_filters(None)                                                          # everything
    c = SimBus(channel)                                                          # attached late
    for aid in (0x181, 0x201):
        a.send(frame(aid))
    sched.run_until(3_000)
    assert got == [0x181, 0x181, 0x182, 0x181, 0x201]
    assert [m.arbitration_id for m in iter(c.recv, None)] == [0x181, 0x201]
    c.shutdown()
    a.send(frame(0x181))
    sched.run_until(4_000)
    assert got[-1] == 0x181 and c.recv() is None


def test_send_frame_is_send_of_a_message(sched, channel):
    """send_frame(id, data) puts the same frame on the wire as send(Message), same errors."""
    a, b = SimBus(channel), SimBus(channel)
    a.send_frame(0x181, b"\x01\x02")
    a.send(frame(0x181, b"\x01\x02"))
    sched.run_until(1_000)
    first, second = b.recv(), b.recv()
    assert first.equals(second, timestamp_delta=None) and first.is_rx and first.dlc == 2
    with pytest.raises(BusError):
        a.send_frame(0x800, b"")
    with pytest.raises(BusError):
        a.send_frame(0x181, bytes(9))
    a.shutdown()
    with pytest.raises(BusError):
        a.send_frame(0x181, b"")


def test_received_message_equals_the_constructor_built_one():
    """The network's fast Message (no __init__) has every field can.Message(...) would give."""
    from bus import network as N

    fast = N._rx_message_fast(1.25, 0x181, b"\x01\x02\x03", "ch", True)
    ref = N._rx_message_init(1.25, 0x181, b"\x01\x02\x03", "ch", True)
    assert N._rx_message is N._rx_message_fast         # python-can's slots are the known ones
    for slot in N._MESSAGE_SLOTS:
        assert getattr(fast, slot) == getattr(ref, slot), slot
        assert type(getattr(fast, slot)) is type(getattr(ref, slot)), slot
    assert fast.equals(ref) and repr(fast) == repr(ref)
