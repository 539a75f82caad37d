"""Safety of the firmware under bad commands and faults (issue 11, defects 1-6).

Board-level checks use the toy plant and a fake bus; the soft-limit checks run the full plant
(host.network.build_network) and measure the axis angle from the plant's own state, not from
anything the firmware reports.
"""

import math
from typing import NamedTuple

import can
import pytest


from boards.axis_controller import DEFAULT_KI, DEFAULT_KP, SLEW_ARCSEC_S, AxisController, AxisMode
from boards.safety import RECOMMENDED_HOST_WATCHDOG_US, SafetyLimits
from bus import protocol as p
from bus.scheduler import Scheduler
from bus.simbus import SimBus
from boards_fakes import FakeBus, ToyAxis, nmt_start
from host.network import build_network
from host.scenario import parse_scenario


def make(host_heartbeat=True, **kw):
    """An axis controller on a toy plant; ``host_heartbeat``: a live host sends its CiA heartbeat
    (0x710) every second from t = 0, which keeps the default 2 s host watchdog fed."""
    s = Scheduler()
    bus = FakeBus()
    plant = ToyAxis(s)
    ax = AxisController(s, bus, 1, read_qei_counts=plant.qei_counts, on_duties=plant.set_duties, **kw)
    ax.start()
    nmt_start(ax)
    if host_heartbeat:
        hb = p.encode_heartbeat(p.NodeState.OPERATIONAL)
        s.call_every(1_000_000, lambda now_us: bus.inject(p.heartbeat_cob_id(p.NODE_HOST), hb),
                     start_us=s.now_us)
    return s, bus, plant, ax


def command(bus, cmd, direction=1, value=0):
    bus.inject(p.axis_command_cob_id(1), p.encode_axis_command(cmd, direction, value))


class Fault(NamedTuple):
    code: int
    detail: int


def faults(bus, node=1):
    """The EMCY frames of ``node`` as (fault code, detail); an EMCY error reset (error code 0) is
    (FAULT_CLEARED, the cleared fault code), as issue 11's FAULT_CLEARED frame was."""
    out = []
    for m in bus.frames(p.emcy_cob_id(node)):
        e = p.decode_emcy(m.data)
        out.append(Fault(p.FaultCode.FAULT_CLEARED, e.fault_code) if e.error_code == 0
                   else Fault(e.fault_code, e.detail))
    return out


# ------------------------------------------------------------------ defect 1: gains without bounds
@pytest.mark.parametrize("cmd,value", [(p.AxisCommand.SET_KP, 0), (p.AxisCommand.SET_KI, 0),
                                       (p.AxisCommand.SET_KP, int(DEFAULT_KP * 1e6 * 5e6)),
                                       (p.AxisCommand.SET_KI, int(DEFAULT_KI * 1e6 * 100))])
def test_gain_outside_the_band_is_refused_and_changes_nothing(cmd, value):
    """SET_KP/SET_KI outside [tuned/4, tuned×4]: refused with FAULT COMMAND_REFUSED, gains kept."""
    s, bus, plant, ax = make()
    command(bus, cmd, 1, value)
    assert (ax.kp, ax.ki) == (DEFAULT_KP, DEFAULT_KI)
    f = faults(bus)[-1]
    assert f.code == p.FaultCode.COMMAND_REFUSED and f.detail == (1 << 8) | cmd


def test_gain_inside_the_band_is_accepted():
    """A gain twice the tuned one is inside the documented band."""
    s, bus, plant, ax = make()
    command(bus, p.AxisCommand.SET_KP, 1, round(2 * DEFAULT_KP * 1e6))
    assert ax.kp == pytest.approx(2 * DEFAULT_KP, rel=1e-3) and faults(bus) == []


def test_stop_works_with_zero_gains_by_cutting_the_duty():
    """Built with Kp = Ki = 0 the PI cannot brake: the supervisor cuts the duty, the axis stops."""
    s, bus, plant, ax = make(kp=0.0, ki=0.0)
    command(bus, p.AxisCommand.OPEN_LOOP, 1, 16000)          # ≈ 9500″/s on the toy plant
    s.run_until(1_000_000)
    assert plant.omega > 5000
    command(bus, p.AxisCommand.STOP)
    s.run_until(2_000_000)
    assert abs(plant.omega) < 1.0 and ax.brake_cut and ax.duties == (0.0, 0.0)
    assert any(f.code == p.FaultCode.BRAKE_CUT for f in faults(bus))


@pytest.mark.parametrize("scale_kp,scale_ki", [(1, 1), (0.25, 0.25), (4, 4), (0.25, 4), (4, 0.25)])
def test_stop_all_from_slew_is_reached_at_any_gain_in_the_band(scale_kp, scale_ki):
    """STOP_ALL from slew: rest within 1 s at the band's corner gains (ramp 0.5 s + margin)."""
    s, bus, plant, ax = make(kp=DEFAULT_KP * scale_kp, ki=DEFAULT_KI * scale_ki)
    command(bus, p.AxisCommand.SLEW)
    s.run_until(2_000_000)
    bus.inject(p.stop_all_cob_id(), p.encode_stop_all())
    s.run_until(3_000_000)
    assert abs(plant.omega) < 50.0


# ------------------------------------------------------------------ defect 2: rate, spoofed LIMIT
def test_velocity_above_the_maximum_rate_is_refused():
    """VELOCITY 10 801″/s > the 3°/s maximum (the highest rate the paper ran, §4): refused
    (reason 2), mode unchanged; 3°/s itself and the slew rate are accepted."""
    s, bus, plant, ax = make()
    command(bus, p.AxisCommand.VELOCITY, 1, 10_801_000)
    assert ax.mode == AxisMode.STOP and ax.setpoint_arcsec_s == 0.0
    assert faults(bus)[-1].detail == (2 << 8) | p.AxisCommand.VELOCITY
    command(bus, p.AxisCommand.VELOCITY, 1, 2**31 - 1)              # the largest value the frame carries
    assert ax.mode == AxisMode.STOP and ax.setpoint_arcsec_s == 0.0
    command(bus, p.AxisCommand.VELOCITY, -1, int(SLEW_ARCSEC_S * 1000))
    assert ax.mode == AxisMode.VELOCITY
    command(bus, p.AxisCommand.VELOCITY, 1, 10_800_000)
    assert ax.mode == AxisMode.VELOCITY and ax.setpoint_arcsec_s == 10_800.0


def test_a_single_spoofed_limit_frame_expires():
    """One LIMIT frame without the reader's 100 ms repeats expires after limit_expiry_us."""
    s, bus, plant, ax = make()
    bus.inject(p.limit_cob_id(3), p.encode_limit(0, p.LimitFlags.HIGH_SOFT_LIMIT, 0))
    command(bus, p.AxisCommand.SLEW, 1)
    assert ax.mode == AxisMode.STOP                          # refused while fresh
    s.run_until(ax.safety.limit_expiry_us + 10_000)
    command(bus, p.AxisCommand.SLEW, 1)
    assert ax.mode == AxisMode.SLEW


def test_a_spoofed_no_limit_frame_does_not_release_an_active_limit():
    """A "no limit" LIMIT frame while the reader's POSITION frames still carry the limit bit: the
    limit stays active and SLEW toward it is refused (found by the 10⁶-frame fuzz, docs/faults.md)."""
    s, bus, plant, ax = make()
    high = p.LimitFlags.HIGH_SOFT_LIMIT
    bus.inject(p.position_cob_id(3), p.encode_position(p.PositionFlags.HIGH_LIMIT, 0, 0))
    bus.inject(p.limit_cob_id(3), p.encode_limit(0, high, 0))
    bus.inject(p.limit_cob_id(3), p.encode_limit(0, 0, 0))           # the spoof
    command(bus, p.AxisCommand.SLEW, 1)
    assert ax.mode == AxisMode.STOP and ax.limit_flags & high
    # the reader clears both: POSITION without the bit, then LIMIT 0 -> released
    bus.inject(p.position_cob_id(3), p.encode_position(0, 0, 0))
    bus.inject(p.limit_cob_id(3), p.encode_limit(0, 0, 0))
    command(bus, p.AxisCommand.SLEW, 1)
    assert ax.mode == AxisMode.SLEW


def test_a_position_frame_limit_bit_alone_brakes_a_slewing_axis():
    """The limit bit of a POSITION frame starts braking even if the LIMIT frame is lost."""
    s, bus, plant, ax = make()
    command(bus, p.AxisCommand.SLEW, 1)
    s.run_until(300_000)
    assert ax.mode == AxisMode.SLEW
    bus.inject(p.position_cob_id(3), p.encode_position(p.PositionFlags.HIGH_LIMIT, 0, 0))
    assert ax.mode == AxisMode.LIMIT_STOP and ax.braking


# ------------------------------------------------------------------ defect 4: host watchdog
def test_host_watchdog_is_on_by_default_and_armed_by_the_first_host_frame():
    """Default safety limits: no host frame at all -> nothing raised; after a host frame, silence
    longer than the default 2 s brakes a slewing axis (issue 11 defect 4)."""
    s, bus, plant, ax = make(host_heartbeat=False)
    assert ax.safety.host_watchdog_us == RECOMMENDED_HOST_WATCHDOG_US
    s.run_until(3 * RECOMMENDED_HOST_WATCHDOG_US)
    assert not ax.host_timed_out
    assert not [x for x in faults(bus) if x.code == p.FaultCode.HOST_TIMEOUT]
    t0 = s.now_us
    command(bus, p.AxisCommand.SLEW)
    s.run_until(t0 + RECOMMENDED_HOST_WATCHDOG_US - 5_000)
    assert ax.mode == AxisMode.SLEW
    s.run_until(t0 + RECOMMENDED_HOST_WATCHDOG_US + 10_000)
    assert ax.mode == AxisMode.STOP and ax.braking and ax.host_timed_out


def test_host_watchdog_stops_a_slewing_axis_and_reports_it():
    """Host silent after SLEW: the axis brakes once the watchdog time has passed, FAULT HOST_TIMEOUT."""
    s, bus, plant, ax = make(host_heartbeat=False,
                             safety=SafetyLimits(host_watchdog_us=RECOMMENDED_HOST_WATCHDOG_US))
    command(bus, p.AxisCommand.SLEW)
    s.run_until(RECOMMENDED_HOST_WATCHDOG_US - 5_000)
    assert ax.mode == AxisMode.SLEW
    s.run_until(RECOMMENDED_HOST_WATCHDOG_US + 10_000)
    assert ax.mode == AxisMode.STOP and ax.braking
    s.run_until(RECOMMENDED_HOST_WATCHDOG_US + 1_000_000)
    assert abs(plant.omega) < 50.0
    f = [x for x in faults(bus) if x.code == p.FaultCode.HOST_TIMEOUT]
    assert len(f) == 1 and f[0].detail == RECOMMENDED_HOST_WATCHDOG_US // 1000


def test_host_heartbeats_keep_the_watchdog_quiet():
    """A host HEARTBEAT (0x710) every second keeps a slewing axis going."""
    s, bus, plant, ax = make(host_heartbeat=False, safety=SafetyLimits(host_watchdog_us=2_000_000))
    command(bus, p.AxisCommand.SLEW)
    hb = p.encode_heartbeat(p.NodeState.OPERATIONAL)
    s.call_every(1_000_000, lambda now: bus.inject(p.heartbeat_cob_id(0x10), hb))
    s.run_until(6_000_000)
    assert ax.mode == AxisMode.SLEW and not any(f.code == p.FaultCode.HOST_TIMEOUT for f in faults(bus))


# ------------------------------------------------------------------ defect 6: faults
def test_over_current_is_reported_once_then_cleared_not_repeated():
    """A current flickering around 6 A: one FAULT OVER_CURRENT, then FAULT_CLEARED once it is gone."""
    amps = [0.0]
    s = Scheduler()
    bus = FakeBus()
    plant = ToyAxis(s)
    ax = AxisController(s, bus, 1, read_qei_counts=plant.qei_counts, on_duties=plant.set_duties,
                        shunt_a_v=lambda: amps[0] * 0.1)
    ax.start()
    nmt_start(ax)
    s.call_every(5_000, lambda now: amps.__setitem__(0, 6.5 if (now // 5_000) % 2 else 5.0)
                 if now < 3_000_000 else amps.__setitem__(0, 1.0), priority=0)
    s.run_until(5_000_000)
    codes = [(f.code, f.detail) for f in faults(bus)]
    assert [c for c, _ in codes] == [p.FaultCode.OVER_CURRENT, p.FaultCode.FAULT_CLEARED]
    assert codes[1][1] == p.FaultCode.OVER_CURRENT


def make_focus_with_two_stalls():
    from boards.focus_controller import FocusController
    s = Scheduler()
    bus = FakeBus()
    st = {"enc": 0, "n": 0}

    def on_step(d):
        st["n"] += 1
        if 20 < st["n"] <= 27 or 300 < st["n"] <= 303:    # 7 lost, later 3 more
            return
        st["enc"] += 5 * d

    f = FocusController(s, bus, 5, on_step=on_step, read_encoder_counts=lambda: st["enc"])
    f.start()
    nmt_start(f)
    return s, bus, f


def test_step_loss_fault_reports_the_true_count_and_later_losses():
    """7 half-steps lost in a burst, 3 more later: the last FAULT STEP_LOSS carries 10."""
    s, bus, f = make_focus_with_two_stalls()
    bus.inject(p.focus_command_cob_id(), p.encode_focus_command(p.FocusCommand.STEP, 400))
    s.run_until(4_000_000)
    sl = [x.detail for x in faults(bus, 5) if x.code == p.FaultCode.STEP_LOSS]
    assert f.missed_steps == 10
    assert sl[-1] == 10 and len(sl) >= 2


# ------------------------------------------------------------------ full plant: defects 1, 3, 5
SCENARIO = """\
name: safety
seed: 1
plant: {preload: low}
faults: []
segments:
  - {name: s, axis: ra, mode: stop, duration_s: 1}
"""


def telescope_at(angle_deg):
    tel = build_network(parse_scenario(SCENARIO, "safety.yaml"))
    tel.plants["ra"].reset(math.radians(angle_deg))
    host = SimBus(network=tel.network, name="test-host")
    host.send(can.Message(arbitration_id=p.nmt_cob_id(), is_extended_id=False,
                          data=p.encode_nmt(p.NmtCommand.START)))     # boards boot PRE-OPERATIONAL
    # a live host: its CiA heartbeat every second keeps the axes' host watchdog (2 s) fed
    hb = can.Message(arbitration_id=p.heartbeat_cob_id(p.NODE_HOST), is_extended_id=False,
                     data=p.encode_heartbeat(p.NodeState.OPERATIONAL))
    tel.scheduler.call_every(1_000_000, lambda now_us: host.send(hb), start_us=tel.scheduler.now_us,
                             owner="test-host-heartbeat")
    return tel, host


def send(host, cmd, direction=1, value=0):
    host.send(can.Message(arbitration_id=p.axis_command_cob_id(1), is_extended_id=False,
                          data=p.encode_axis_command(cmd, direction, value)))


def run_max_angle(tel, until_us):
    top = -1e9
    s = tel.scheduler
    while s.now_us < until_us:
        s.run_until(s.now_us + 10_000)
        tel.plants["ra"].advance_to(s.now_us)
        top = max(top, math.degrees(tel.plants["ra"].axis_angle_rad))
    return top


@pytest.mark.parametrize("start_deg, cmd, value", [
    (94.5, p.AxisCommand.SLEW, 0), (94.0, p.AxisCommand.SLEW, 0), (94.8, p.AxisCommand.SET, 0),
    (94.0, p.AxisCommand.VELOCITY, 10_800_000),      # the highest commanded rate, 3°/s (milli-″/s)
])
def test_motion_started_at_rest_near_the_limit_stops_before_it(start_deg, cmd, value):
    """At rest inside the approach zone, a fast command toward the limit: the setpoint ramps at
    the braking deceleration, so the reader's rate-based zone is not outrun by the PI's step
    response (the fuzz found DEC 350″ past its limit after a SLEW from rest 0.54° short of it)."""
    tel, host = telescope_at(start_deg)
    try:
        tel.scheduler.run_until(200_000)
        send(host, cmd, +1, value)
        top = run_max_angle(tel, 4_000_000)
        assert start_deg < top < 95.0
        assert abs(tel.plants["ra"].axis_rate_arcsec_s) < 50.0
    finally:
        tel.close()


def test_slew_into_the_soft_limit_stops_before_it():
    """SLEW toward +95°: the axis (plant truth) stops before 95°, within 1.3 braking zones of it."""
    tel, host = telescope_at(88.0)
    try:
        send(host, p.AxisCommand.SLEW, +1)
        top = run_max_angle(tel, 8_000_000)
        zone = tel.boards["ra-reader"].safety.braking_distance_arcsec(SLEW_ARCSEC_S) / 3600
        assert 95.0 - 1.3 * zone < top < 95.0
        assert abs(tel.plants["ra"].axis_rate_rad_s) * 206265 < 5.0
    finally:
        tel.close()


def test_zero_gains_cannot_be_set_so_the_limit_still_stops_a_slew():
    """SET_KP 0 and SET_KI 0 during a slew (issue 11: RA reached 136°): refused, stop before 95°."""
    tel, host = telescope_at(88.0)
    try:
        send(host, p.AxisCommand.SLEW, +1)
        tel.scheduler.run_until(1_500_000)                  # at slew rate, ≈ 91°
        assert tel.plants["ra"].axis_rate_rad_s * 206265 > 7000
        send(host, p.AxisCommand.SET_KP, 1, 0)
        send(host, p.AxisCommand.SET_KI, 1, 0)
        assert run_max_angle(tel, 8_000_000) < 95.0
    finally:
        tel.close()


def test_reader_power_loss_stops_the_slew_and_refuses_motion():
    """The RA reader loses power mid-slew: FAULT READER_LOST, the axis stops, SLEW refused."""
    tel, host = telescope_at(80.0)
    try:
        send(host, p.AxisCommand.SLEW, +1)
        tel.scheduler.run_until(1_000_000)
        tel.boards["ra-reader"].power_off()
        top = run_max_angle(tel, 6_000_000)
        ax = tel.boards["ra-axis"]
        assert top < 85.0 and ax.reader_lost == 1
        assert abs(tel.plants["ra"].axis_rate_rad_s) * 206265 < 5.0
        send(host, p.AxisCommand.SLEW, +1)
        tel.scheduler.run_until(6_100_000)
        assert ax.mode == AxisMode.STOP and ax.refused_commands >= 1
    finally:
        tel.close()


def test_reader_reporting_invalid_stops_the_axis_and_the_fault_clears_later():
    """POSITION flag 'invalid' while slewing: braking stop, FAULT READER_LOST 2; valid frames
    again: FAULT_CLEARED (detail 9) once the condition has been gone for 1 s."""
    s, bus, plant, ax = make()
    valid = [True]

    def position(now):
        flags = 0 if valid[0] else p.PositionFlags.INVALID
        bus.inject(p.position_cob_id(3), p.encode_position(flags, 0, 0))
    s.call_every(10_000, position)
    command(bus, p.AxisCommand.SLEW)
    s.run_until(1_000_000)
    valid[0] = False
    s.run_until(2_000_000)
    assert ax.mode == AxisMode.STOP and abs(plant.omega) < 50.0 and ax.reader_lost == 2
    valid[0] = True
    s.run_until(3_500_000)
    got = [(f.code, f.detail) for f in faults(bus)]
    assert got == [(p.FaultCode.READER_LOST, 2), (p.FaultCode.FAULT_CLEARED, p.FaultCode.READER_LOST)]
    command(bus, p.AxisCommand.SLEW)
    assert ax.mode == AxisMode.SLEW


def test_open_loop_overspeed_is_braked_and_reported():
    """OPEN_LOOP at full duty drives the toy axis past overspeed_factor × the maximum rate:
    braking stop, FAULT OVERSPEED. (The toy drive tops out near 14 700″/s, under 1.5 × the
    default 3°/s maximum, so the test sets the maximum to the slew rate.)"""
    safety = SafetyLimits(max_rate_arcsec_s=SLEW_ARCSEC_S)
    s, bus, plant, ax = make(safety=safety)
    command(bus, p.AxisCommand.OPEN_LOOP, 1, 32767)          # toy plant: 19 550″/s at full duty
    peak = [0.0]
    s.call_every(5_000, lambda now: peak.__setitem__(0, max(peak[0], abs(plant.omega))))
    s.run_until(6_000_000)
    assert ax.mode == AxisMode.STOP and abs(plant.omega) < 50.0
    f = [x for x in faults(bus) if x.code == p.FaultCode.OVERSPEED]
    limit = safety.overspeed_factor * safety.max_rate_arcsec_s
    assert len(f) == 1 and f[0].detail > limit and peak[0] < 19_550


def test_a_flood_of_malformed_frames_is_counted_but_faults_are_rate_limited():
    """1000 malformed frames in 1 s: all counted; FAULT MALFORMED ≤ burst 4 + 10 per second,
    so the board's own transmit queue stays free for its safety frames."""
    s, bus, plant, ax = make()
    bad = p.encode_axis_command(p.AxisCommand.SLEW, 1, 0)[:5]          # wrong DLC
    s.call_every(1_000, lambda now: bus.inject(p.axis_command_cob_id(1), bad))
    s.run_until(1_000_000)
    assert ax.malformed_frames == 1000
    n = sum(1 for f in faults(bus) if f.code == p.FaultCode.MALFORMED_FRAME)
    assert 4 <= n <= 4 + 10 + 1
