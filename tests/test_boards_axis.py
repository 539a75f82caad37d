"""Specification of the axis controller firmware (dsPIC30F3011) against a toy plant and a fake bus."""

import can
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from boards.axis_controller import (PRESET_RATES_ARCSEC_S, SLEW_ARCSEC_S, AxisController,
                                    AxisMode)
from bus import protocol as p
from bus.scheduler import Scheduler
from boards_fakes import FakeBus, ToyAxis, nmt_start

CMD = p.axis_command_cob_id(1)


def make(node=1, rx_interrupt=True, **kw):
    s = Scheduler()
    bus = FakeBus(rx_interrupt=rx_interrupt)
    plant = ToyAxis(s)
    ax = AxisController(s, bus, node, read_qei_counts=plant.qei_counts,
                        on_duties=plant.set_duties, **kw)
    ax.start()
    nmt_start(ax)
    return s, bus, plant, ax


def command(bus, cmd, direction=1, value=0, node=1):
    bus.inject(p.axis_command_cob_id(node), p.encode_axis_command(cmd, direction, value))


def test_slew_rate_is_table1_motor_speed_over_gear_ratio():
    """SLEW = 12.583 rad/s / 360.489 at the axis ≈ 2°/s (7199.748″/s, as documented)."""
    assert SLEW_ARCSEC_S == pytest.approx(7199.748, abs=0.001)
    assert PRESET_RATES_ARCSEC_S[AxisMode.TRACK] == (15.0, 0.0)


def test_closed_loop_reaches_preset_rate_and_reports_status_every_10_ms():
    """SET (600″/s) is reached by the toy plant; AXIS_STATUS and AXIS_AUX come every 10 ms."""
    s, bus, plant, ax = make()
    command(bus, p.AxisCommand.SET, +1)
    s.run_until(2_000_000)
    assert ax.mode == AxisMode.SET
    assert plant.omega == pytest.approx(600.0, rel=0.02)
    st_frames = bus.frames(p.axis_status_cob_id(1))
    aux = bus.frames(p.axis_aux_cob_id(1))
    assert len(st_frames) == len(aux) == 200
    times = [i * 10_000 for i in range(1, 201)]
    last = p.decode_axis_status(st_frames[-1].data)
    assert last.mode == p.AxisMode.SET and last.u_q15 == round(ax.u * 32767)
    assert p.decode_axis_aux(aux[-1].data).seq == 200 % 256
    assert len(times) == 200


def test_velocity_quantisation_is_2_3_arcsec_s_per_count():
    """One QEI count per 5 ms tick is 2.296″/s of axis rate (4.608e6 × 24.5 counts/rev)."""
    _, _, _, ax = make()
    assert ax.rate_per_count == pytest.approx(2.296, abs=1e-3)


def test_direction_minus_drives_motor_b():
    """A negative preset gives U < 0: motor B gets |U|, motor A gets p·|U|."""
    s, bus, plant, ax = make(counter_fraction=0.2)
    command(bus, p.AxisCommand.GUIDE, -1)
    s.run_until(1_000_000)
    a, b = ax.duties
    assert ax.u < 0 and b == pytest.approx(abs(ax.u), abs=1e-3) and a == pytest.approx(0.2 * b, abs=1e-3)
    assert plant.omega == pytest.approx(-100.0, rel=0.05)


def test_bumpless_transfer_keeps_u_and_applies_one_ordinary_increment():
    """At a preset change U_k = U_{k−1} + Kp(E_k − E_{k−1}) + Ki·E_k: U is not re-initialised."""
    s, bus, plant, ax = make()
    command(bus, p.AxisCommand.SET, +1)
    s.run_until(1_000_000)
    u_before, e_prev = ax.u, ax.pi.e_prev
    command(bus, p.AxisCommand.GUIDE, +1)          # between ticks
    assert ax.u == u_before                         # a mode change alone does not move U
    s.run_until(1_005_000)                          # next tick
    e_k = 100.0 - ax.omega_arcsec_s
    expected = u_before + ax.kp * (e_k - e_prev) + ax.ki * e_k
    assert ax.u == pytest.approx(expected, rel=1e-12, abs=1e-15)
    # the jump is bounded by Kp·|ΔE| + Ki·|E|, and ΔE ≈ Δω_sp = −500″/s here
    assert abs(ax.u - u_before) <= ax.kp * abs(e_k - e_prev) + ax.ki * abs(e_k) + 1e-12


def test_open_loop_applies_fixed_duty_without_feedback():
    """OPEN_LOOP duty_q15 sets U directly; the PI does not act."""
    s, bus, plant, ax = make()
    command(bus, p.AxisCommand.OPEN_LOOP, +1, 16384)
    s.run_until(500_000)
    assert ax.u == pytest.approx(16384 / 32767)
    assert ax.duties[0] == pytest.approx(16384 / 32767, abs=1 / 3000)


def test_set_kp_and_ki_in_micro_duty_units():
    """SET_KP/SET_KI values are gain × 1e6 with the gain in duty/(″/s)."""
    s, bus, plant, ax = make()
    command(bus, p.AxisCommand.SET_KP, 0, 1234)
    command(bus, p.AxisCommand.SET_KI, 0, 56)
    assert ax.kp == pytest.approx(1.234e-3) and ax.ki == pytest.approx(5.6e-5)


def limit_frame(flags, axis=0, pos=0):
    return p.encode_limit(axis, flags, pos)


def test_limit_frame_stops_axis_and_refuses_motion_toward_limit():
    """A LIMIT in the direction of motion → LIMIT_STOP; motion toward it refused, away allowed."""
    s, bus, plant, ax = make()
    command(bus, p.AxisCommand.SET, +1)
    s.run_until(500_000)
    bus.inject(p.limit_cob_id(3), limit_frame(p.LimitFlags.HIGH_SOFT_LIMIT))
    # the reader repeats an active LIMIT every 100 ms (a single frame would expire)
    flags = [p.LimitFlags.HIGH_SOFT_LIMIT]
    s.call_every(100_000, lambda now: bus.inject(p.limit_cob_id(3), limit_frame(flags[0])))
    assert ax.mode == AxisMode.LIMIT_STOP and ax.braking     # braking ramp from the measured rate
    faults = [p.decode_emcy(m.data) for m in bus.frames(p.emcy_cob_id(1))]
    assert faults[-1].fault_code == p.FaultCode.LIMIT_STOP and faults[-1].error_code == 0x8612
    s.run_until(560_000)                                 # 600″/s at 14 400″/s² → 42 ms ramp
    assert ax.setpoint_arcsec_s == 0.0
    s.run_until(1_500_000)
    assert abs(plant.omega) < 5.0                        # stopped (and held)
    status = p.decode_axis_status(bus.frames(p.axis_status_cob_id(1))[-1].data)
    assert status.mode == p.AxisMode.LIMIT_STOP and status.flags & p.AxisStatusFlags.LIMIT_STOP
    command(bus, p.AxisCommand.SLEW, +1)                 # toward the limit: refused
    assert ax.mode == AxisMode.LIMIT_STOP and ax.limit_refusals == 1
    refused = p.decode_emcy(bus.frames(p.emcy_cob_id(1))[-1].data)
    assert refused.fault_code == p.FaultCode.COMMAND_REFUSED and refused.detail == (4 << 8) | p.AxisCommand.SLEW
    command(bus, p.AxisCommand.GUIDE, -1)                # away: accepted
    assert ax.mode == AxisMode.GUIDE and ax.setpoint_arcsec_s == -100.0
    s.run_until(1_505_000)                               # the limit stop has ended: error reset
    reset = p.decode_emcy(bus.frames(p.emcy_cob_id(1))[-1].data)
    assert reset.error_code == 0 and reset.detail == 0x8612 and reset.fault_code == p.FaultCode.LIMIT_STOP
    flags[0] = 0
    bus.inject(p.limit_cob_id(3), limit_frame(0))        # limit left: nothing else changes
    assert ax.mode == AxisMode.GUIDE


def test_limit_clear_returns_limit_stop_to_stop():
    """LIMIT_STOP becomes STOP when the reader reports the limit cleared."""
    s, bus, plant, ax = make()
    command(bus, p.AxisCommand.FINE, -1)
    bus.inject(p.limit_cob_id(3), limit_frame(p.LimitFlags.LOW_SOFT_LIMIT))
    assert ax.mode == AxisMode.LIMIT_STOP
    bus.inject(p.limit_cob_id(3), limit_frame(0))
    assert ax.mode == AxisMode.STOP


def test_limit_from_the_other_axis_reader_is_filtered_out():
    """The DEC reader's LIMIT (0x074) never reaches the RA controller's handler."""
    s, bus, plant, ax = make()
    command(bus, p.AxisCommand.SET, +1)
    bus.inject(p.limit_cob_id(4), limit_frame(p.LimitFlags.HIGH_SOFT_LIMIT, axis=1))
    assert ax.mode == AxisMode.SET and ax.malformed_frames == 0


@settings(max_examples=300, suppress_health_check=[HealthCheck.too_slow])
@given(arb=st.sampled_from([CMD, p.limit_cob_id(3), p.stop_all_cob_id()]),
       data=st.binary(min_size=0, max_size=8), rtr=st.booleans())
def test_malformed_frames_are_counted_and_never_raise(arb, data, rtr):
    """Random payload/DLC on an accepted id: decoded or counted + EMCY MALFORMED_FRAME, never an
    exception."""
    s, bus, plant, ax = make()
    before = ax.malformed_frames
    try:
        if arb == CMD:
            p.decode_axis_command(data)
        elif arb == p.stop_all_cob_id():
            p.decode_stop_all(data)
        else:
            p.decode_limit(data)
            if data[1] != 0:
                raise p.MalformedFrame("LIMIT", "axis", "0")
        valid = not rtr
    except Exception:
        valid = False
    bus.inject(arb, data, is_remote_frame=rtr, dlc=len(data))
    s.run_until(20_000)
    if valid:
        assert ax.malformed_frames == before
    else:
        assert ax.malformed_frames == before + 1
        f = p.decode_emcy(bus.frames(p.emcy_cob_id(1))[-1].data)
        assert f.fault_code == p.FaultCode.MALFORMED_FRAME and f.detail == arb
        assert f.error_code == 0x8200 and f.count == ax.malformed_frames


def test_heartbeat_every_second_and_sdo_answers_the_health_check():
    """CiA heartbeat: boot-up ``00`` at boot, then the NMT state (OPERATIONAL after the start)
    every 1 s (0x1017); an SDO upload of 0x1000 on 0x601 is answered on 0x581, one to another
    node is not (acceptance filter)."""
    s, bus, plant, ax = make()
    s.run_until(3_000_000)
    hb = [p.decode_heartbeat(m.data) for m in bus.frames(p.heartbeat_cob_id(1))]
    assert [h.state for h in hb] == [p.NodeState.BOOT] + [p.NodeState.OPERATIONAL] * 3
    upload = bytes((0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0))
    bus.inject(p.sdo_request_cob_id(1), upload)
    (answer,) = bus.frames(p.sdo_response_cob_id(1))
    assert answer.data[:4] == bytes((0x43, 0x00, 0x10, 0x00))
    assert int.from_bytes(answer.data[4:], "little") == p.DeviceType.AXIS_CONTROLLER << 16
    bus.inject(p.sdo_request_cob_id(2), upload)                     # other node
    assert len(bus.frames(p.sdo_response_cob_id(1))) == 1 and not bus.frames(p.sdo_response_cob_id(2))


def test_reset_restores_power_on_state_keeps_cause():
    """NMT reset node: mode STOP, U 0, counters cleared; reset cause SOFTWARE and the count
    survive; reboots into PRE-OPERATIONAL (commands ignored until NMT start)."""
    s, bus, plant, ax = make()
    command(bus, p.AxisCommand.SET, +1)
    bus.inject(CMD, b"\x10\x63")                         # malformed
    s.run_until(500_000)
    assert ax.malformed_frames == 1 and ax.u != 0
    bus.inject(p.nmt_cob_id(), p.encode_nmt(p.NmtCommand.RESET_NODE, 1))
    assert ax.mode == AxisMode.STOP and ax.u == 0 and ax.malformed_frames == 0
    assert ax.reset_cause == "software" and ax.reset_count == 1 and ax.duties == (0.0, 0.0)
    hb = p.decode_heartbeat(bus.frames(p.heartbeat_cob_id(1))[-1].data)
    assert hb.state == p.NodeState.BOOT and ax.device.state == "PRE-OPERATIONAL"
    command(bus, p.AxisCommand.SET, +1)
    assert ax.mode == AxisMode.STOP and ax.device.rpdos_ignored == 1
    s.run_until(1_000_000)
    assert ax.timer.ticks == 100                       # ISR rescheduled after the reboot
    ax.reset("watchdog")                               # e.g. the injected watchdog fault
    emcy = p.decode_emcy(bus.frames(p.emcy_cob_id(1))[-1].data)
    assert emcy.fault_code == p.FaultCode.WATCHDOG and emcy.detail == 2 and ax.reset_count == 2


def test_polling_without_rx_interrupt_services_every_waiting_frame():
    """On a bus without rx callback the firmware polls; every frame waiting in the bus's queue
    is serviced at the poll (the two-buffer overrun is modelled only with the interrupt, where
    frames arrive at wire times: boards/peripherals.py CanController.poll)."""
    s, bus, plant, ax = make(rx_interrupt=False)
    for _ in range(3):
        command(bus, p.AxisCommand.SET_KP, 0, 1000)
    s.run_until(5_000)
    assert ax.can.rx_overflows == 0 and ax.can.rx_frames == 3


def test_overcurrent_is_flagged_not_tripped_by_default():
    """Shunt ADC above 6 A sets the status flag and sends FAULT(3); the drive keeps running."""
    s = Scheduler()
    bus = FakeBus()
    plant = ToyAxis(s)
    ax = AxisController(s, bus, 1, read_qei_counts=plant.qei_counts, on_duties=plant.set_duties,
                        shunt_a_v=lambda: 0.7, shunt_b_v=lambda: 0.1)
    ax.start()
    nmt_start(ax)
    command(bus, p.AxisCommand.SET, +1)
    s.run_until(20_000)
    assert ax.overcurrent and not ax.tripped and ax.mode == AxisMode.SET
    assert ax.adc_a == int(0.7 / 5 * 1024)
    assert p.decode_axis_status(bus.frames(p.axis_status_cob_id(1))[-1].data).flags & 4
    emcy = [p.decode_emcy(m.data) for m in bus.frames(p.emcy_cob_id(1))]
    assert [e.fault_code for e in emcy] == [p.FaultCode.OVER_CURRENT]     # one EMCY, not one per tick


def test_unknown_drive_law_is_rejected_at_construction():
    """law must name an entry of DRIVE_LAWS."""
    with pytest.raises(ValueError, match="proportional"):
        make(law="bang-bang")
