"""Specification of the peripheral models (PWM, QEI, ADC, CAN controller, timer, step/dir)."""

import can
import pytest
from hypothesis import given
from hypothesis import strategies as st

from boards.peripherals import Adc, CanController, Pwm, Qei, StepDir, Timer, Uart
from bus.scheduler import Scheduler
from boards_fakes import FakeBus


def test_pwm_duty_resolution_is_3000_steps_at_20_khz_30_mips():
    """PTPER = 1499; duties quantised to 1/3000; on_change gets the quantised pair."""
    seen = []
    pwm = Pwm(2, lambda a, b: seen.append((a, b)))
    assert pwm.ptper == 1499 and pwm.steps == 3000
    pwm.set_duties(0.50001, 1.7)
    assert seen[-1] == (0.5, 1.0)
    pwm.disable()
    assert seen[-1] == (0.0, 0.0)


@given(st.lists(st.integers(-30_000, 30_000), min_size=1, max_size=200))
def test_qei_extension_tracks_cumulative_count_through_16_bit_wraps(steps):
    """The 32-bit software extension equals the port's count whatever the 16-bit wraps."""
    count = [123_456]
    q = Qei(lambda: count[0])
    q.reset()
    total = 0
    for d in steps:
        count[0] += d
        assert q.read_delta() == d
        total += d
        assert q.extended == total
        assert 0 <= q.poscnt < 65536


def test_adc_is_10_bit_floor_with_clipping():
    """counts = floor(V/5·1024) clipped to 0..1023."""
    adc = Adc({"x": lambda: 0.6})
    assert adc.sample("x") == 122
    assert adc.to_counts(-1) == 0 and adc.to_counts(7.0) == 1023


def test_can_controller_two_buffers_overflow_counted():
    """Three frames pending when the receive interrupt is serviced: two kept, one lost and
    counted (the MCP2515's two buffers, on a bus that delivers at wire times)."""
    bus = FakeBus()
    got = []
    c = CanController(bus)
    c.on_rx = got.append
    c.enable_rx_interrupt()
    for i in range(3):
        bus._rx.append(can.Message(arbitration_id=0x201, data=bytes(8), is_extended_id=False))
    c._rx_interrupt()
    assert len(got) == 2 and c.rx_overflows == 1


def test_polled_can_controller_services_every_waiting_frame():
    """On a bus without a receive interrupt (virtual, SocketCAN) a poll services every accepted
    frame that waited in the bus's queue: the poll period must not lose frames."""
    bus = FakeBus(rx_interrupt=False)
    got = []
    c = CanController(bus)
    c.accept = lambda i: i == 0x201
    c.on_rx = got.append
    for i in range(5):
        bus._rx.append(can.Message(arbitration_id=0x201, data=bytes(8), is_extended_id=False))
    bus._rx.append(can.Message(arbitration_id=0x181, data=bytes(8), is_extended_id=False))
    c.poll()
    assert len(got) == 5 and c.rx_overflows == 0 and c.rx_frames == 5


def test_can_controller_acceptance_filter_drops_foreign_ids_silently():
    """Frames failing the acceptance filter never reach a buffer nor count as overflow."""
    bus = FakeBus()
    got = []
    c = CanController(bus)
    c.accept = lambda i: i == 0x201
    c.on_rx = got.append
    c.enable_rx_interrupt()
    bus.inject(0x181, bytes(8))
    bus.inject(0x201, bytes(8))
    assert [m.arbitration_id for m in got] == [0x201] and c.rx_overflows == 0


def test_timer_fires_every_period_from_start():
    """Timer ISR at start+period, start+2·period ... with the scheduler's time."""
    s = Scheduler()
    seen = []
    t = Timer(s, 5_000, seen.append)
    t.start()
    s.run_until(20_000)
    assert seen == [5_000, 10_000, 15_000, 20_000]
    t.reset()
    s.run_until(40_000)
    assert len(seen) == 4


def test_stepdir_steps_only_when_powered():
    """No step pulses reach the port in hold or free power states."""
    steps = []
    sd = StepDir(steps.append)
    sd.set_direction(-1)
    sd.step()
    sd.set_power("hold")
    sd.step()
    assert steps == [-1] and sd.steps_issued == -1
    with pytest.raises(ValueError):
        sd.set_power("off")


def test_uart_fifo_overrun_counted():
    """A 4-byte receive FIFO: the fifth byte is lost and counted."""
    u = Uart()
    u.feed(b"12345")
    assert u.read() == b"1234" and u.rx_overruns == 1
