"""Specification of bus.network: exact CAN 2.0A frame length, arbitration, load statistics."""

import random

import can
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import bus  # noqa: F401  (registers schmidt-sim)
from bus.errors import BusError
from bus.network import (CanNetwork, clear_frame_bits_cache, crc15, frame_bits,
                         frame_bits_unstuffed, get_network)
from bus.scheduler import PRIO_BACKGROUND, PRIO_CAN, PRIO_HOST, PRIO_ISR, Scheduler
from bus.simbus import SimBus


# -- an independent, slow, bit-by-bit reference ----------------------------------------------
def ref_frame_bits(arbitration_id, data):
    bits = [0]                                                   # SOF
    bits += [(arbitration_id >> (10 - i)) & 1 for i in range(11)]
    bits += [0, 0, 0]                                            # RTR, IDE, r0
    bits += [(len(data) >> (3 - i)) & 1 for i in range(4)]       # DLC
    for byte in data:
        bits += [(byte >> (7 - i)) & 1 for i in range(8)]
    crc = 0
    for b in bits:                                               # ISO 11898-1 CRC-15
        nxt = b ^ ((crc >> 14) & 1)
        crc = (crc << 1) & 0x7FFF
        if nxt:
            crc ^= 0x4599
    bits += [(crc >> (14 - i)) & 1 for i in range(15)]
    stuffed, run_value, run_len = 0, None, 0
    for b in bits:
        if b == run_value:
            run_len += 1
        else:
            run_value, run_len = b, 1
        if run_len == 5:
            stuffed += 1
            run_value, run_len = 1 - b, 1                        # the stuff bit starts a run
    return len(bits) + stuffed + 1 + 1 + 1 + 7 + 3


@pytest.fixture
def sched():
    return Scheduler()


@pytest.fixture
def net(sched, request):
    network = CanNetwork(sched, f"net-{request.node.name}")
    yield network
    network.close()


def make_bus(net, **kw):
    return SimBus(network=net, **kw)


def msg(aid, data=bytes(8)):
    return can.Message(arbitration_id=aid, data=data, is_extended_id=False)


def test_unstuffed_lengths_match_facts():
    """An 8-byte frame with no stuffing is 111 bits; an empty one 47 (incl. 3-bit intermission)."""
    assert frame_bits_unstuffed(8) == 111 and frame_bits_unstuffed(0) == 47
    rng = random.Random(7)
    lengths = [frame_bits(rng.randrange(0x800), bytes(rng.randrange(256) for _ in range(8)))
               for _ in range(5000)]
    assert min(lengths) >= 111 and max(lengths) <= 135
    assert 2.5 < sum(lengths) / len(lengths) - 111 < 4.5   # FACTS: random data ≈ 3.3 stuff bits


def test_known_frames():
    """Known frames: all-zero 8-byte frame at id 0 and id 0x7FF, and an empty frame."""
    for aid, data in [(0, bytes(8)), (0x7FF, bytes(8)), (0x7FF, b"\xff" * 8), (0x181, b""),
                      (0x555, b"\x55" * 8), (0x123, b"\x01\x02\x03")]:
        assert frame_bits(aid, data) == ref_frame_bits(aid, data), (hex(aid), data)
    assert 111 <= frame_bits(0, bytes(8)) <= 135


@settings(max_examples=2000, deadline=None)
@given(st.integers(0, 0x7FF), st.binary(min_size=0, max_size=8))
def test_frame_bits_equals_bitwise_reference(aid, data):
    """frame_bits equals the bit-by-bit reference for every id and payload."""
    clear_frame_bits_cache()
    assert frame_bits(aid, data) == ref_frame_bits(aid, data)


@settings(max_examples=500, deadline=None)
@given(st.integers(0, 0x7FF), st.binary(min_size=0, max_size=8))
def test_both_frame_bits_paths_equal_the_reference(aid, data):
    """The compiled bit-serial kernel (bus.bitkernel) and the interpreted table version (the
    fallback without numba) both equal the bit-by-bit reference."""
    from bus import bitkernel
    from bus.network import _frame_bits_tables

    ref = ref_frame_bits(aid, data)
    assert _frame_bits_tables(aid, data) == ref
    v = int.from_bytes(data, "big")
    assert bitkernel.frame_bits_kernel(aid, len(data), v >> 32, v & 0xFFFFFFFF) == ref
    source = getattr(bitkernel.frame_bits_kernel, "py_func", bitkernel.frame_bits_kernel)
    assert source(aid, len(data), v >> 32, v & 0xFFFFFFFF) == ref     # the kernel interpreted


def test_frame_bits_bounds():
    """8-byte frames take 111..135 bits."""
    rng = random.Random(1)
    for _ in range(2000):
        n = frame_bits(rng.randrange(0x800), bytes(rng.randrange(256) for _ in range(8)))
        assert 111 <= n <= 135


def test_crc15_known_value():
    """CRC-15 of a single 1 bit is the polynomial itself."""
    assert crc15(1, 1) == 0x4599
    assert crc15(0, 40) == 0


def test_frame_occupies_bus_for_frame_bits_and_is_delivered_at_end(sched, net):
    """A frame sent at t is received at t + frame_bits µs, timestamp in seconds."""
    tx, rx = make_bus(net), make_bus(net)
    data = bytes(range(8))
    sched.call_at(1000, lambda now: tx.send(msg(0x181, data)))
    sched.run_until(1000 + frame_bits(0x181, data) - 1)
    assert rx.recv() is None
    sched.run_until(2000)
    got = rx.recv()
    assert got.arbitration_id == 0x181 and bytes(got.data) == data
    assert got.timestamp == pytest.approx((1000 + frame_bits(0x181, data)) / 1e6)
    assert tx.recv() is None


def test_arbitration_lowest_identifier_wins_at_same_microsecond(sched, net):
    """Three nodes submitting in the same µs are sent lowest identifier first, back to back."""
    a, b, c, rx = (make_bus(net) for _ in range(4))
    order = []

    def submit(now):
        a.send(msg(0x300))
        b.send(msg(0x100))
        c.send(msg(0x200))

    sched.call_at(500, submit, PRIO_ISR)
    sched.run_until(5_000)
    while (m := rx.recv()) is not None:
        order.append((m.arbitration_id, round(m.timestamp * 1e6)))
    t1 = 500 + frame_bits(0x100, bytes(8))
    t2 = t1 + frame_bits(0x200, bytes(8))
    t3 = t2 + frame_bits(0x300, bytes(8))
    assert order == [(0x100, t1), (0x200, t2), (0x300, t3)]
    stats = net.stats()
    assert stats["max_latency_us"] == {0x100: 0, 0x200: t1 - 500, 0x300: t2 - 500}


@pytest.mark.parametrize("first", [PRIO_ISR, PRIO_CAN, PRIO_BACKGROUND, PRIO_HOST])
def test_every_frame_of_the_same_microsecond_competes_whatever_submitted_it(sched, net, first):
    """On an idle bus, frames made ready in the same µs by a background loop, an ISR, a receive
    handler or the host all take part in the first arbitration: the lowest identifier is sent
    first, whichever event submitted first (ISO 11898-1: every node ready before the
    start-of-frame bit arbitrates). Before session 22 the first background loop's frame went
    first whatever its identifier."""
    a, b, c, rx = (make_bus(net) for _ in range(4))
    order = []
    # the highest identifier is submitted by the event that runs first at t = 500 µs
    sched.call_at(500, lambda now: a.send(msg(0x300)), first)
    sched.call_at(500, lambda now: b.send(msg(0x100)), PRIO_HOST)
    sched.call_at(500, lambda now: c.send(msg(0x200)), PRIO_BACKGROUND)
    sched.run_until(5_000)
    while (m := rx.recv()) is not None:
        order.append((m.arbitration_id, round(m.timestamp * 1e6)))
    t1 = 500 + frame_bits(0x100, bytes(8))
    t2 = t1 + frame_bits(0x200, bytes(8))
    assert order == [(0x100, t1), (0x200, t2), (0x300, t2 + frame_bits(0x300, bytes(8)))]


def test_each_node_transmits_in_submission_order(sched, net):
    """A node's own frames leave in the order submitted, even if a later one has a lower id."""
    a, b, rx = make_bus(net), make_bus(net), make_bus(net)

    def submit(now):
        a.send(msg(0x300))
        a.send(msg(0x100))
        b.send(msg(0x200))

    sched.call_at(0, submit)
    sched.run_until(1_000)
    assert [rx.recv().arbitration_id for _ in range(3)] == [0x200, 0x300, 0x100]


def test_frame_submitted_while_busy_waits_for_idle(sched, net):
    """A high-priority frame does not pre-empt a frame already on the wire."""
    a, b, rx = make_bus(net), make_bus(net), make_bus(net)
    sched.call_at(0, lambda now: a.send(msg(0x700)))
    sched.call_at(10, lambda now: b.send(msg(0x000)))
    sched.run_until(1_000)
    first, second = rx.recv(), rx.recv()
    assert (first.arbitration_id, second.arbitration_id) == (0x700, 0x000)
    end1 = frame_bits(0x700, bytes(8))
    assert round(second.timestamp * 1e6) == end1 + frame_bits(0x000, bytes(8))
    assert net.stats()["max_latency_us"][0x000] == end1 - 10


def test_bus_load_of_periodic_traffic(sched, net):
    """One fixed frame every 1 ms for 1 s loads the bus by frame_bits/1000 (µs per µs)."""
    tx, _rx = make_bus(net), make_bus(net)
    data = bytes([1, 2, 3, 4, 5, 6, 7, 8])
    sched.call_every(1_000, lambda now: tx.send(msg(0x181, data)))   # 1 ms, 2 ms, ... 1000 ms
    sched.run_until(1_000_000)
    st_ = net.stats()
    bits = frame_bits(0x181, data)
    assert st_["per_id"] == {0x181: 1000}
    assert st_["busy_us"] == 1000 * bits == st_["bits"]
    assert st_["load_pct"] == pytest.approx(100 * bits / 1000)
    assert st_["peak_load_pct"] == pytest.approx(100 * bits / 1000)


def test_peak_load_over_100ms_windows(sched, net):
    """A burst in one 100 ms window shows as the peak, not diluted by the idle windows."""
    tx, _rx = make_bus(net), make_bus(net)
    for i in range(100):
        sched.call_at(150_000, lambda now: tx.send(msg(0x181, bytes([0xAA] * 8))))
    sched.run_until(1_000_000)
    busy = 100 * frame_bits(0x181, bytes([0xAA] * 8))
    s = net.stats()
    assert s["peak_load_pct"] == pytest.approx(100 * busy / 100_000)
    assert s["load_pct"] == pytest.approx(100 * busy / 1_000_000)


def test_slower_bitrate_scales_duration(sched, request):
    """At 500 kbit/s a frame takes twice as many µs as bits."""
    net = CanNetwork(sched, f"slow-{request.node.name}", bitrate=500_000)
    try:
        tx, rx = make_bus(net), make_bus(net)
        tx.send(msg(0x181))
        sched.run_until(1000)
        assert round(rx.recv().timestamp * 1e6) == 2 * frame_bits(0x181, bytes(8))
    finally:
        net.close()


def test_determinism(request):
    """Same traffic, same result: identical receive traces and statistics."""
    def run(tag):
        s = Scheduler()
        n = CanNetwork(s, f"det-{tag}-{request.node.name}")
        buses = [SimBus(network=n) for _ in range(6)]
        rng = random.Random(42)
        for i, b in enumerate(buses[:5]):
            s.call_every(5_000 + i, lambda now, b=b, i=i: b.send(
                msg(0x180 + i, bytes(rng.randrange(256) for _ in range(8)))), start_us=0)
        s.run_until(200_000)
        trace = []
        while (m := buses[5].recv()) is not None:
            trace.append((m.arbitration_id, m.timestamp, bytes(m.data)))
        stats = n.stats()
        n.close()
        return trace, stats

    assert run("a") == run("b")


def test_registry(sched, request):
    """get_network finds a channel; a second network on it raises unless replace=True."""
    name = f"reg-{request.node.name}"
    first = CanNetwork(sched, name)
    assert get_network(name) is first
    with pytest.raises(BusError, match="already exists"):
        CanNetwork(sched, name)
    second = CanNetwork(sched, name, replace=True)
    assert get_network(name) is second and first.closed
    second.close()
    with pytest.raises(BusError, match="no CanNetwork"):
        get_network(name)


def test_refuses_frames_it_does_not_emulate(sched, net):
    """Extended ids, ids above 0x7FF, remote frames and >8 bytes raise BusError."""
    tx = make_bus(net)
    with pytest.raises(BusError):
        tx.send(can.Message(arbitration_id=0x181, data=bytes(8), is_extended_id=True))
    with pytest.raises(BusError):
        tx.send(can.Message(arbitration_id=0x800, data=bytes(8), is_extended_id=False))
    with pytest.raises(BusError):
        tx.send(can.Message(arbitration_id=0x181, is_remote_frame=True, is_extended_id=False))


def _reference_schedule(subs, detach_at, bits):
    """Independent model of CAN arbitration: per-node FIFOs; whenever the bus is idle the head
    frame with the lowest identifier (then the earliest submitted) goes; frames submitted at the
    instant the bus frees compete. ``subs`` = [(t_us, node, aid, data)] in submission order;
    ``detach_at`` = {node: t_us} (its queued frames are dropped then). Returns [(end_us, aid, node)].
    """
    queues = {}
    order = sorted(range(len(subs)), key=lambda k: (subs[k][0], k))
    i, t, out = 0, 0, []
    while True:
        while i < len(order) and subs[order[i]][0] <= t:
            k = order[i]          # i = rank in submission order (the tie-break of equal ids)
            queues.setdefault(subs[k][1], []).append((subs[k][2], i, k))
            i += 1
        for node, td in detach_at.items():
            if td <= t:
                queues.pop(node, None)
        heads = [(q[0], node) for node, q in queues.items() if q]
        if not heads:
            if i == len(order):
                return out
            t = max(t, subs[order[i]][0])
            continue
        (aid, _, k), node = min(heads)
        queues[node].pop(0)
        t += bits(aid, subs[k][3])
        out.append((t, aid, node))


def test_arbitration_of_many_nodes_matches_an_independent_model(sched, net):
    """Twelve nodes submitting random frames at random (often equal) times, one of them detached
    mid-run with frames queued: every frame arrives when and in the order the reference model of
    lowest-identifier-first arbitration with per-node FIFOs says (checks the heap of queue heads
    and the identifier -> receivers table against a model written without them)."""
    rng = random.Random(12)
    nodes = [make_bus(net, name=f"n{k}") for k in range(12)]
    monitor = make_bus(net, name="monitor")
    got = []
    monitor.set_rx_callback(lambda: got.extend(
        (round(m.timestamp * 1e6), m.arbitration_id, m.data[0]) for m in iter(monitor.recv, None)))
    subs = []
    for _ in range(400):
        t = rng.choice([0, 1000, 2000, 2500]) + rng.randrange(0, 20_000, rng.choice([1, 500]))
        node = rng.randrange(12)
        aid = rng.choice([0x181, 0x182, 0x281, 0x701, 0x080 + node, rng.randrange(0x800)])
        data = bytes([node]) + bytes(rng.randrange(256) for _ in range(rng.randrange(8)))
        if not (node == 5 and t >= 9_001):     # node 5 is detached at 9001 µs
            subs.append((t, node, aid, data))
    for t, node, aid, data in subs:          # submission order = this order at equal times
        sched.call_at(t, lambda now, b=nodes[node], a=aid, d=data: b.send(msg(a, d)), PRIO_ISR)
    detach_at = {5: 9_001}
    sched.call_at(9_001, lambda now: nodes[5].shutdown(), PRIO_ISR)
    sched.run_until(200_000)
    expected = _reference_schedule(subs, detach_at, frame_bits)
    assert got == expected
    assert len(got) < len(subs) and any(node == 5 for _, _, node in got)


def test_arbitration_heap_pops_in_key_order():
    """The arbitration heap (bus.network._heads_push/_heads_pop) against a sorted list, on random
    interleavings of pushes and pops (keys unique, as (identifier << 48) | seq are)."""
    import random

    from bus.network import _heads_pop, _heads_push, _Pending

    rng = random.Random(5)
    for trial in range(300):
        heap: list = []
        ref: list = []
        seq = 0
        for _ in range(rng.randrange(1, 60)):
            if ref and rng.random() < 0.4:
                got = _heads_pop(heap)
                ref.sort(key=lambda p: p.key)
                assert got is ref.pop(0)
            else:
                seq += 1
                p = _Pending(None, rng.randrange(0x800), b"", 0, seq)
                _heads_push(heap, p)
                ref.append(p)
        ref.sort(key=lambda p: p.key)
        assert [_heads_pop(heap) for _ in range(len(heap))] == ref
