"""Transmit priority of a node with three hardware transmit buffers, from the datasheets' words
(bus.network.TxBuffers; boards.peripherals.tx_priority is the firmware's TXP choice).

MCP2515 DS21801 §3.2 "Transmit Priority" (PIC18F2480/2580/4480/4580 DS39637 §24.6.3, same
words): "Prior to sending the SOF, the priority of all buffers that are queued for transmission
is compared. The transmit buffer with the highest priority will be sent first. ... If two
buffers have the same priority setting, the buffer with the highest buffer number will be sent
first." It is "independent from ... any prioritization implicit in the message arbitration
scheme built into the CAN protocol". Expected orders below are worked out by hand from those
sentences and the documented firmware policy (oldest waiting frame into the lowest-numbered free
buffer when one frees), not read from the code's output.
"""

import can
import pytest

import bus  # noqa: F401  (registers schmidt-sim)
from boards.peripherals import TX_BUFFERS, CanController, tx_priority
from bus.errors import BusError
from bus.network import CanNetwork
from bus.scheduler import PRIO_ISR, Scheduler
from bus.simbus import SimBus


@pytest.fixture
def rig(request):
    sched = Scheduler()
    net = CanNetwork(sched, f"txbuf-{request.node.name}", replace=True)
    blocker = SimBus(network=net, name="blocker")       # keeps the bus busy while frames load
    node = SimBus(network=net, name="node")
    monitor = SimBus(network=net, name="monitor")
    seen = []
    monitor.set_rx_callback(lambda: seen.extend(m.arbitration_id for m in iter(monitor.recv, None)))
    yield sched, net, blocker, node, seen
    net.close()


def _load_while_busy(sched, blocker, node, ids):
    """The blocker's frame occupies the bus from t = 0; at t = 10 µs the node's firmware sends
    ``ids`` in this order (so they all wait for the same SOF)."""
    sched.call_at(0, lambda now: blocker.send(can.Message(arbitration_id=0x001, data=bytes(8),
                                                          is_extended_id=False)), PRIO_ISR)
    for aid in ids:
        sched.call_at(10, lambda now, a=aid: node.send_frame(a, bytes(8)), PRIO_ISR)
    sched.run_until(10_000)


def test_equal_priority_highest_buffer_number_first(rig):
    """TXP equal: TXB2 before TXB1 before TXB0 whatever the identifiers (0x100 < 0x200 < 0x300
    would be the bus's order; the controller offers one frame at a time)."""
    sched, net, blocker, node, seen = rig
    node.set_tx_buffers(3, lambda aid: 0)
    _load_while_busy(sched, blocker, node, [0x100, 0x200, 0x300])   # -> TXB0, TXB1, TXB2
    assert seen == [0x001, 0x300, 0x200, 0x100]


def test_higher_txp_first_then_buffer_number(rig):
    """TXB0 with TXP 3 goes first; TXB1 and TXB2 share TXP 0: TXB2, then TXB1."""
    sched, net, blocker, node, seen = rig
    node.set_tx_buffers(3, lambda aid: 3 if aid == 0x400 else 0)
    _load_while_busy(sched, blocker, node, [0x400, 0x200, 0x300])
    assert seen == [0x001, 0x400, 0x300, 0x200]


def test_frames_beyond_three_wait_in_the_firmware_fifo(rig):
    """Five frames, equal TXP: A, B, C fill TXB0..2; D, E wait. C (TXB2) goes; its buffer frees
    and takes D, the highest number again; then E likewise; then B (TXB1), A (TXB0)."""
    sched, net, blocker, node, seen = rig
    node.set_tx_buffers(3, lambda aid: 0)
    a, b, c, d, e = 0x10A, 0x10B, 0x10C, 0x10D, 0x10E
    _load_while_busy(sched, blocker, node, [a, b, c, d, e])
    assert seen == [0x001, c, d, e, b, a]


def test_a_node_without_buffers_keeps_its_fifo(rig):
    """A python-can user's bus (no set_tx_buffers call) stays one FIFO: submission order."""
    sched, net, blocker, node, seen = rig
    _load_while_busy(sched, blocker, node, [0x300, 0x100, 0x200])
    assert seen == [0x001, 0x300, 0x100, 0x200]


def test_the_offered_frame_still_meets_bus_arbitration(rig):
    """The controller's choice is local: its offered frame (TXB1, 0x300) loses the bus to another
    node's lower identifier (0x050) pending at the same SOF, then goes before its own 0x100."""
    sched, net, blocker, node, seen = rig
    node.set_tx_buffers(3, lambda aid: 0)
    sched.call_at(10, lambda now: blocker.send_frame(0x050, bytes(8)), PRIO_ISR)
    _load_while_busy(sched, blocker, node, [0x100, 0x300])
    assert seen == [0x001, 0x050, 0x300, 0x100]


def test_an_errored_frame_stays_in_its_buffer(rig):
    """A transmit error does not give the buffer up: the frame is compared again before the next
    SOF and, still the highest (TXB1 over TXB0, equal TXP), is retransmitted first."""
    sched, net, blocker, node, seen = rig
    node.set_tx_buffers(3, lambda aid: 0)
    net.inject_errors(ids=[0x300], count=1, start_us=0)
    _load_while_busy(sched, blocker, node, [0x100, 0x300])
    assert seen == [0x001, 0x300, 0x100]
    assert net.error_state(node).retransmissions == 1


def test_the_boards_txp_choice_puts_a_status_before_its_own_heartbeat(rig):
    """The boards' controller (three buffers, boards.peripherals.tx_priority): a heartbeat
    (0x70D, TXP 0) queued before the node's status (0x18D, TXP 2) no longer holds the status back
    (the DOME_STATUS jitter of docs/conformance.md); EMCY (0x08D, TXP 3) goes before both."""
    sched, net, blocker, node, seen = rig
    ctrl = CanController(node)
    assert TX_BUFFERS == 3 and [tx_priority(i) for i in (0x08D, 0x18D, 0x28D, 0x58D, 0x70D)] == [3, 2, 1, 0, 0]
    sched.call_at(0, lambda now: blocker.send_frame(0x001, bytes(8)), PRIO_ISR)
    for aid in (0x70D, 0x18D, 0x08D):
        sched.call_at(10, lambda now, a=aid: ctrl.send(a, bytes(8)), PRIO_ISR)
    sched.run_until(10_000)
    assert seen == [0x001, 0x08D, 0x18D, 0x70D]


def test_buffers_are_set_only_on_an_idle_node(rig):
    sched, net, blocker, node, seen = rig
    sched.call_at(0, lambda now: blocker.send_frame(0x001, bytes(8)), PRIO_ISR)
    sched.call_at(10, lambda now: node.send_frame(0x100, bytes(8)), PRIO_ISR)
    sched.run_until(20)
    with pytest.raises(BusError):
        node.set_tx_buffers(3, lambda aid: 0)


def _reference(subs, buffered, txp, bits):
    """Independent model: ``subs`` = [(t_us, node, aid, data)] in submission order. Nodes in
    ``buffered`` have three buffers (lowest free one loaded from a FIFO; offered: highest TXP,
    then highest buffer number); the others offer their FIFO head. When the bus is free, the
    offered frame with the lowest identifier (then the earliest submitted) goes. Frames submitted
    up to and at a frame's end time are queued before its buffer frees (the boards' ISRs run
    before frame completion at an instant). Returns [(end_us, aid, node)]."""
    order = sorted(range(len(subs)), key=lambda k: (subs[k][0], k))
    fifo, bufs = {}, {n: [None, None, None] for n in buffered}
    i, t, out, sending = 0, 0, [], None

    def load(node):
        b = bufs[node]
        for j in range(3):
            if b[j] is None and fifo.get(node):
                b[j] = fifo[node].pop(0)

    def arrive_until(t):
        nonlocal i
        while i < len(order) and subs[order[i]][0] <= t:
            k = order[i]
            node = subs[k][1]
            fifo.setdefault(node, []).append((subs[k][2], i, k))
            if node in bufs:
                load(node)
            i += 1

    while True:
        arrive_until(t)
        if sending is not None:                 # the frame ending now frees its buffer
            node, j = sending
            bufs[node][j] = None
            load(node)
            sending = None
        offers = []
        for node in set(fifo) | set(bufs):
            if node in bufs:
                cand = [(txp(node, e[0]), j, e) for j, e in enumerate(bufs[node]) if e is not None]
                if cand:
                    _, j, e = max(cand, key=lambda c: (c[0], c[1]))
                    offers.append((e[0], e[1], node, j, e))
            elif fifo.get(node):
                e = fifo[node][0]
                offers.append((e[0], e[1], node, None, e))
        if not offers:
            if i == len(order):
                return out
            t = max(t, subs[order[i]][0])
            continue
        aid, _, node, j, e = min(offers, key=lambda o: (o[0], o[1]))
        if j is None:
            fifo[node].pop(0)
        else:
            sending = (node, j)
        t += bits(aid, subs[e[2]][3])
        out.append((t, aid, node))


def test_many_buffered_nodes_match_an_independent_model():
    """Ten nodes (seven with three buffers and a random TXP per identifier, three plain FIFOs)
    submitting random frames at random, often equal, times: every frame arrives when and in the
    order the model written from the datasheet rule says (checks the arbitration heap's handling
    of a node whose offered frame changes)."""
    import random

    from bus.network import frame_bits

    rng = random.Random(7)
    sched = Scheduler()
    net = CanNetwork(sched, "txbuf-many", replace=True)
    buffered = set(range(7))
    table = {(n, a): rng.randrange(4) for n in range(10) for a in range(0x800)}
    txp = lambda node, aid: table[(node, aid)]          # noqa: E731
    nodes = [SimBus(network=net, name=f"n{k}") for k in range(10)]
    for k in buffered:
        nodes[k].set_tx_buffers(3, lambda aid, k=k: txp(k, aid))
    monitor = SimBus(network=net, name="monitor")
    got = []
    monitor.set_rx_callback(lambda: got.extend(
        (round(m.timestamp * 1e6), m.arbitration_id, m.data[0]) for m in iter(monitor.recv, None)))
    subs = []
    for _ in range(600):
        t = rng.choice([0, 1000, 2000]) + rng.randrange(0, 30_000, rng.choice([1, 111, 500]))
        node = rng.randrange(10)
        aid = rng.choice([0x181, 0x281, 0x701, 0x080 + node, rng.randrange(0x800)])
        data = bytes([node]) + bytes(rng.randrange(256) for _ in range(rng.randrange(8)))
        subs.append((t, node, aid, data))
    for t, node, aid, data in subs:
        sched.call_at(t, lambda now, b=nodes[node], a=aid, d=data: b.send_frame(a, d), PRIO_ISR)
    sched.run_until(400_000)
    try:
        assert got == _reference(subs, buffered, txp, frame_bits)
        assert len(got) == len(subs)
    finally:
        net.close()
