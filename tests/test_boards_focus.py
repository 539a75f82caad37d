"""Specification of the focus controller firmware (PIC18F4431, node 5)."""

from bus import protocol as p
from bus.scheduler import Scheduler
from boards.focus_controller import FocusController
from boards_fakes import FakeBus, nmt_start


def make(**kw):
    s = Scheduler()
    bus = FakeBus()
    steps, power = [], []
    f = FocusController(s, bus, 5, on_step=steps.append, read_lvdt_v=lambda: 2.5,
                        on_power=power.append, **kw)
    f.start()
    nmt_start(f)
    return s, bus, f, steps, power


def cmd(bus, c, value=0):
    bus.inject(p.focus_command_cob_id(), p.encode_focus_command(c, value))


def test_step_command_issues_half_steps_at_the_step_rate():
    """STEP +10 gives 10 half steps at 400/s (2.5 ms apart); position counts them."""
    s, bus, f, steps, _ = make()
    cmd(bus, p.FocusCommand.STEP, 10)
    s.run_until(12_500)
    assert steps == [1] * 5
    s.run_until(100_000)
    assert steps == [1] * 10 and f.pos_halfsteps == 10 and not f.moving


def test_move_to_is_absolute_and_refused_outside_travel():
    """MOVE_TO −800 (−5 mm) is absolute; −5000 is outside the ±800 travel: refused, no step."""
    s, bus, f, steps, _ = make()
    cmd(bus, p.FocusCommand.MOVE_TO, -800)
    s.run_until(3_000_000)
    assert f.pos_halfsteps == -800 and steps.count(-1) == 800
    cmd(bus, p.FocusCommand.MOVE_TO, -5000)
    cmd(bus, p.FocusCommand.STEP, -1)
    s.run_until(4_000_000)
    assert f.pos_halfsteps == f.target_halfsteps == -800 and len(steps) == 800
    faults = [p.decode_emcy(m.data) for m in bus.frames(p.emcy_cob_id(5))]
    assert [(x.fault_code, x.detail) for x in faults] == [
        (p.FaultCode.COMMAND_REFUSED, 6 << 8 | p.FocusCommand.MOVE_TO),
        (p.FaultCode.COMMAND_REFUSED, 6 << 8 | p.FocusCommand.STEP)]


def test_focus_status_every_250_ms_with_lvdt_counts():
    """FOCUS_STATUS every 250 ms: LVDT 10-bit counts, half-step position, moving flag."""
    s, bus, f, steps, _ = make()
    cmd(bus, p.FocusCommand.STEP, 200)
    s.run_until(1_000_000)
    st = [p.decode_focus_status(m.data) for m in bus.frames(p.focus_status_cob_id())]
    assert len(st) == 4
    assert st[0].lvdt_adc == 512 and st[0].flags & p.FocusFlags.MOVING
    assert st[-1].pos_halfsteps == 200 and not st[-1].flags & p.FocusFlags.MOVING


def test_hold_and_free_power_states():
    """HOLD → holding flag and port 'hold'; FREE → power-off flag and port 'free'."""
    s, bus, f, steps, power = make()
    cmd(bus, p.FocusCommand.HOLD)
    s.run_until(250_000)
    assert power[-1] == "hold"
    assert p.decode_focus_status(bus.frames(p.focus_status_cob_id())[-1].data).flags == p.FocusFlags.HOLDING
    cmd(bus, p.FocusCommand.FREE)
    s.run_until(500_000)
    assert p.decode_focus_status(bus.frames(p.focus_status_cob_id())[-1].data).flags == p.FocusFlags.POWER_OFF
    cmd(bus, p.FocusCommand.STEP, 1)
    assert power[-1] == "on"


def test_index_pulse_latched_until_reported():
    """A rising index edge during a move sets INDEX_SEEN in the next status only."""
    level = {"v": False}
    s = Scheduler()
    bus = FakeBus()
    f = FocusController(s, bus, 5, on_step=lambda d: level.update(v=(f.pos_halfsteps + d) == 50),
                        read_index=lambda: level["v"])
    f.start()
    nmt_start(f)
    cmd(bus, p.FocusCommand.STEP, 100)
    s.run_until(500_000)
    st = [p.decode_focus_status(m.data) for m in bus.frames(p.focus_status_cob_id())]
    assert st[0].flags & p.FocusFlags.INDEX_SEEN and not st[1].flags & p.FocusFlags.INDEX_SEEN


def test_malformed_focus_command_counted():
    """Unknown FOCUS_COMMAND cmd → malformed_frames + EMCY MALFORMED_FRAME."""
    s, bus, f, steps, _ = make()
    bus.inject(p.focus_command_cob_id(), bytes([0x10, 9, 0, 0, 0, 0, 0, 0]))
    assert f.malformed_frames == 1
    assert p.decode_emcy(bus.frames(p.emcy_cob_id(5))[-1].data).fault_code == p.FaultCode.MALFORMED_FRAME


def make_with_encoder(lose=0):
    """Focus board on a toy stepper whose encoder (5 counts per half-step) skips the first
    ``lose`` commanded half-steps after 20 steps (a stall)."""
    s = Scheduler()
    bus = FakeBus()
    st = {"enc": 0, "n": 0, "lose": lose}

    def on_step(d):
        st["n"] += 1
        if st["n"] > 20 and st["lose"] > 0:
            st["lose"] -= 1
            return
        st["enc"] += 5 * d

    f = FocusController(s, bus, 5, on_step=on_step, read_encoder_counts=lambda: st["enc"])
    f.start()
    nmt_start(f)
    return s, bus, f, st


def test_focus_status_reports_encoder_counts():
    """FOCUS_STATUS b6–7 carries the motor encoder count (low 16 bits), 5 counts per half-step;
    negative positions wrap as the 16-bit POSCNT does."""
    s, bus, f, st = make_with_encoder()
    cmd(bus, p.FocusCommand.STEP, -30)
    s.run_until(500_000)
    last = p.decode_focus_status(bus.frames(p.focus_status_cob_id())[-1].data)
    assert last.pos_halfsteps == -30 and last.enc_counts == (-150) & 0xFFFF
    assert f.enc_counts == -150 and f.missed_steps == 0
    assert not last.flags & p.FocusFlags.STEP_LOSS


def test_missed_steps_detected_counted_and_reported():
    """Seven half-steps lost by the motor: the firmware counts 7 missed steps, flags STEP_LOSS in
    the next FOCUS_STATUS only, and sends one FAULT STEP_LOSS with the count."""
    s, bus, f, st = make_with_encoder(lose=7)
    cmd(bus, p.FocusCommand.STEP, 100)
    s.run_until(750_000)
    assert f.pos_halfsteps == 100 and st["enc"] == 5 * 93
    assert f.missed_steps == 7 and f.step_deviation == -7
    sts = [p.decode_focus_status(m.data) for m in bus.frames(p.focus_status_cob_id())]
    flagged = [bool(x.flags & p.FocusFlags.STEP_LOSS) for x in sts]
    assert flagged == [True, False, False]
    faults = [p.decode_emcy(m.data) for m in bus.frames(p.emcy_cob_id(5))]
    assert [x.fault_code for x in faults] == [p.FaultCode.STEP_LOSS]
    assert 1 <= faults[0].detail <= 7        # sent at the first detection, while steps were lost


def test_no_missed_steps_when_the_encoder_follows():
    """An encoder that follows every step: no missed steps over a long move back and forth."""
    s, bus, f, st = make_with_encoder()
    cmd(bus, p.FocusCommand.MOVE_TO, 800)
    s.run_until(2_100_000)
    cmd(bus, p.FocusCommand.MOVE_TO, -800)
    s.run_until(6_500_000)
    assert f.pos_halfsteps == -800 and f.enc_counts == -4000 and f.missed_steps == 0
