"""CAN fault confinement on the emulated bus (ISO 11898-1 §12): error frames, TEC/REC, states."""

import can
import pytest

from boards.peripherals import CanController
from bus.network import (BUS_OFF, ERROR_ACTIVE, ERROR_FRAME_BITS, ERROR_PASSIVE, CanNetwork,
                         frame_bits)
from bus.scheduler import Scheduler
from bus.simbus import SimBus


def net3(ch):
    s = Scheduler()
    n = CanNetwork(s, ch, replace=True)
    a, b, c = (SimBus(network=n, name=x) for x in ("a", "b", "c"))
    return s, n, a, b, c


def msg(aid, data=b"\x01\x02\x03\x04\x05\x06\x07\x08"):
    return can.Message(arbitration_id=aid, data=data, is_extended_id=False)


def test_corrupted_frame_is_an_error_frame_then_retransmitted_once():
    """One error: partial frame + 23-bit error frame on the wire, TEC 8→7, REC 1→0, one delivery."""
    s, n, a, b, c = net3("f1")
    n.inject_errors(ids=[0x123], count=1)
    a.send(msg(0x123))
    s.run_until(10_000)
    got = [b.recv(), b.recv()]
    assert got[0] is not None and got[1] is None and bytes(got[0].data) == bytes(range(1, 9))
    fb = frame_bits(0x123, bytes(range(1, 9)))
    st = n.stats()
    assert st["error_frames"] == 1 and st["frames"] == 1
    err_part = st["error_bits"]
    assert ERROR_FRAME_BITS + 2 <= err_part <= ERROR_FRAME_BITS + fb - 12
    assert st["bits"] == fb + err_part                    # the error bits occupied the bus
    assert got[0].timestamp == pytest.approx((fb + err_part) / 1e6)
    assert a.error_state.tec == 7 and a.error_state.tx_errors == 1
    assert b.error_state.rec == 0 and b.error_state.rx_errors == 1
    assert a.error_state.retransmissions == 1


def test_error_passive_at_tec_128_and_suspend_lets_a_higher_id_through():
    """16 transmit errors: TEC 128 → error-passive; during its 8-bit suspend B's 0x200 wins."""
    s, n, a, b, c = net3("f2")
    n.inject_errors(sender=a, count=16)
    a.send(msg(0x100))
    b.send(msg(0x200))
    order, states = [], []
    n.add_tap(lambda m: order.append(m.arbitration_id))
    while s.step():
        states.append(a.error_state.state)
    assert ERROR_PASSIVE in states
    assert order == [0x200, 0x100]          # active A would have won all 16 retries by its lower id
    assert a.error_state.tec == 127 and a.error_state.state == ERROR_ACTIVE   # 128 − 1 success


def test_bus_off_after_tec_255_then_recovery_after_128_x_11_recessive_bits():
    """32 errors → TEC 256 > 255 → bus-off, send refused; recovery takes 1408 idle bit times."""
    s, n, a, b, c = net3("f3")
    n.drive_bus_off(a)
    a.send(msg(0x050))
    s.run_until(100_000)
    es = a.error_state
    assert es.state == BUS_OFF and es.tec == 256 and es.bus_off_count == 1
    assert b.recv() is None
    assert b.error_state.rec == 32 and b.error_state.state == ERROR_ACTIVE
    with pytest.raises(can.CanOperationError):
        a.send(msg(0x050))
    t0 = s.now_us
    a.request_recovery()
    s.run_until(t0 + 128 * 11 - 1)
    assert a.error_state.state == BUS_OFF
    s.run_until(t0 + 128 * 11)
    assert a.error_state.state == ERROR_ACTIVE and a.error_state.tec == 0
    a.send(msg(0x050))
    s.run_until(s.now_us + 1_000)
    assert b.recv() is not None


def test_recovery_counts_busy_frames_as_occurrences():
    """While the bus is busy, each completed frame counts as one 11-recessive-bit occurrence."""
    s, n, a, b, c = net3("f3b")
    n.drive_bus_off(a)
    a.send(msg(0x050))
    s.run_until(50_000)
    t0 = s.now_us
    a.request_recovery()
    # c keeps the bus busy back to back: 300 frames of ~120 bits, no idle gap of 11 bits
    for _ in range(300):
        c.send(msg(0x300, bytes(8)))
    s.run_until(t0 + 128 * 11)
    assert a.error_state.state == BUS_OFF       # idle time alone would have recovered by now
    s.run_until(t0 + 130 * frame_bits(0x300, bytes(8)))
    assert a.error_state.state == ERROR_ACTIVE


def test_frame_loss_hides_a_frame_from_chosen_receivers_only():
    """A ``loss`` rule: the frame is on the wire, c does not get it, b does."""
    s, n, a, b, c = net3("f4")
    n.inject_errors(kind="loss", ids=[0x10], receivers=[c], count=1)
    a.send(msg(0x10))
    a.send(msg(0x10))
    s.run_until(10_000)
    assert b.rx_pending == 2 and c.rx_pending == 1 and c.error_state.frames_lost == 1


def test_babbling_node_starves_higher_ids_until_it_stops():
    """A babbling 0x001 wins every arbitration: 0x100 waits until the babbler stops."""
    s, n, a, b, c = net3("f5")
    n.babble(0x001, end_us=5_000)
    s.run_until(100)
    a.send(msg(0x100))
    seen = []
    n.add_tap(lambda m: seen.append((m.arbitration_id, round(m.timestamp * 1e6))))
    s.run_until(20_000)
    t100 = [t for i, t in seen if i == 0x100]
    assert len(t100) == 1 and t100[0] > 5_000
    assert sum(1 for i, _ in seen if i == 0x001) > 30


def test_probabilistic_errors_are_reproducible_from_the_seed():
    """Same seed, same errors: the RNG belongs to the network."""
    def run(seed):
        s, n, a, b, c = net3("f6")
        n.seed(seed)
        n.inject_errors(probability=0.3)
        for k in range(50):
            a.send(msg(0x100 + k))
        s.run_until(100_000)
        return n.error_counters(), n.stats()["bits"]
    assert run(7) == run(7)
    assert run(7) != run(8)


def test_can_controller_exposes_tec_rec_and_state_registers():
    """The board's CAN controller reads TEC/REC/state from the bus model like hardware registers."""
    s, n, a, b, c = net3("f7")
    ctl = CanController(a)
    n.inject_errors(sender=a, count=20)
    ctl.send(0x100, bytes(8))
    s.run_until(50_000)
    assert (ctl.tec, ctl.error_state) == (160 - 1, ERROR_PASSIVE)
    assert CanController(b).rec == 20 - 1          # 20 receive errors, 1 good frame
    n.drive_bus_off(a)
    ctl.send(0x100, bytes(8))
    s.run_until(100_000)
    assert ctl.error_state == BUS_OFF and ctl.tec == 255
    assert not ctl.send(0x100, bytes(8)) and ctl.tx_errors == 1


def test_fault_free_network_counts_no_errors():
    """No fault injected: zero errors, the old path (and timing) unchanged."""
    s, n, a, b, c = net3("f8")
    a.send(msg(0x100))
    s.run_until(1_000)
    m = b.recv()
    assert m.timestamp == pytest.approx(frame_bits(0x100, bytes(range(1, 9))) / 1e6)
    assert all(v["tec"] == v["rec"] == 0 for v in n.error_counters().values())
