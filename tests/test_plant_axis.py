"""AxisPlant physics: signs, energy, lock-rotor frequency, backlash, static friction map, effects."""

from __future__ import annotations

import math

import pytest

from plant.axis import ARCSEC_PER_RAD, AxisPlant
from plant.effects import build_effect
from plant.params import load_parameters


#: These tests check the motor, gear and friction laws one at a time: the gear-train torque lines
#: (identified RA stage-1 mesh, tests/test_gear_train_disturbance.py) are switched off here.
NO_LINES = {"axes.ra.gear_disturbance.stage1_mesh.amplitude_nm": 0.0}


def plant(**overrides):
    return AxisPlant(load_parameters(overrides={**NO_LINES, **overrides}).ra)


def pi_run(ax, setpoint_arcsec_s, ticks, kp=1e-3, ki=1e-4):
    """Paper §4 incremental PI on the true rate with the proportional preload law (test-only)."""
    u, e_prev = 0.0, 0.0
    c = ax.params.drive.counter_fraction
    t = ax.now_us
    for _ in range(ticks):
        e = setpoint_arcsec_s - ax.axis_rate_arcsec_s
        u = min(1.0, max(-1.0, u + kp * (e - e_prev) + ki * e))
        e_prev = e
        ax.set_duties(u, c * u) if u >= 0 else ax.set_duties(-c * u, -u)
        t += 5_000
        ax.advance_to(t)
    return u


def test_signs_motor_a_pushes_positive_b_negative():
    """Duty on motor A turns the axis +, on motor B −; currents never go negative."""
    for duties, sign in (((0.6, 0.0), 1.0), ((0.0, 0.6), -1.0)):
        ax = plant()
        ax.set_duties(*duties)
        for k in range(1, 201):
            ax.advance_to(k * 5_000)
            assert min(ax.motor_current_a) >= 0.0
        assert sign * ax.axis_rate_rad_s > 0.0
        assert sign * ax.axis_angle_rad > 0.0


def test_current_clamped_at_zero_when_back_driven():
    """A motor spun in its push direction faster than its no-load speed carries zero current."""
    ax = plant(**{"perfect": True})
    ax.axis_rate_rad_s = 0.05
    ax.motor_a_rate_rad_s = ax.motor_b_rate_rad_s = 0.05 * ax.params.gear.ratio  # EMF 6.3 V
    ax.set_duties(0.1, 0.0)  # 2.4 V < EMF on motor A
    ax.advance_to(5_000)
    assert ax.motor_current_a[0] == 0.0
    assert ax.motor_current_a[1] > 0.0  # motor B is plugged: EMF drives current through it


def test_energy_never_increases_without_input():
    """With zero duties stored energy only decreases (perfect plant, then full LuGre overall)."""
    for perfect in (True, False):
        ax = plant(perfect=perfect)
        w0 = 2e-3
        ax.axis_rate_rad_s = w0
        ax.motor_a_rate_rad_s = ax.motor_b_rate_rad_s = w0 * ax.params.gear.ratio
        e_prev = e0 = ax.stored_energy_j()
        for k in range(1, 401):
            ax.advance_to(k * 1_000)
            e = ax.stored_energy_j()
            if perfect:
                assert e <= e_prev * (1 + 1e-9) + 1e-12
            e_prev = e
        assert e_prev < 0.5 * e0


def test_lock_rotor_frequency_table1():
    """Locked rotors, J = 2.2e6 N·mm·s², Table 1 stiffness: axis rings at 5.96 Hz (RA)."""
    ax = plant(**{
        "perfect": True,
        "axes.ra.inertia_kg_m2": 2200.0,
        "axes.ra.gear.damping_ratio": 0.0,
        "axes.ra.friction.low.sigma2_nm_s_rad": 0.0,
        "axes.ra.motor.rotor_inertia_kg_m2": 1e3,  # rotors effectively locked
    })
    ax.axis_rate_rad_s = 1e-4
    crossings, prev, t_prev = [], ax.axis_rate_rad_s, 0.0
    for k in range(1, 2001):
        ax.advance_to(k * 1_000)
        w, t = ax.axis_rate_rad_s, k * 1e-3
        if (prev > 0) != (w > 0):
            crossings.append(t_prev + (t - t_prev) * prev / (prev - w))
        prev, t_prev = w, t
    period = 2 * (crossings[-1] - crossings[0]) / (len(crossings) - 1)
    assert 1 / period == pytest.approx(5.96, abs=0.02)
    assert math.sqrt(3.08e9 / 2.2e6) / (2 * math.pi) == pytest.approx(5.96, abs=0.01)


def test_backlash_dead_zone_then_engages():
    """A motor parked on the far flank turns ≈21° freely, then its train engages."""
    ax = plant()
    n = ax.params.gear.ratio
    ax.motor_a_angle_rad -= ax.backlash_rad * n  # other flank of train A's dead zone
    start = ax.motor_a_angle_rad
    ax.set_duties(0.05, 0.0)  # 1.2 V: far too little to break the axis free
    free_deg, engaged = None, False
    for k in range(1, 3001):
        ax.advance_to(k * 100)
        moved_deg = math.degrees(ax.motor_a_angle_rad - start)
        if ax.gear_torque_nm[0] > 0.0 and not engaged:
            engaged, free_deg = True, moved_deg
        if not engaged:
            assert ax.gear_torque_nm[0] == 0.0
    assert engaged
    assert free_deg == pytest.approx(21.0, abs=0.5)
    assert abs(ax.axis_angle_rad) * ARCSEC_PER_RAD < 0.5  # the axis stayed (presliding only)


@pytest.mark.parametrize("preload", ["low", "high"])
def test_steady_state_matches_lugre_static_map(preload):
    """At steady sliding the delivered gear torque equals Tc + (Ts−Tc)e^{−(ω/ωs)^δ} + σ2ω."""
    cases = ((0.3, 1), (0.6, 1), (0.6, -1)) if preload == "low" else ((0.9, 1), (0.9, -1))  # breakaway
    for duty, sign in cases:
        ax = plant(**{"axes.ra.friction.preload": preload})
        ax.set_duties(duty, 0.25 * duty) if sign > 0 else ax.set_duties(0.25 * duty, duty)
        ax.advance_to(4_000_000)
        w = ax.axis_rate_rad_s
        assert sign * w > 10 * ax.friction.omega_s_rad_s
        assert sum(ax.gear_torque_nm) == pytest.approx(ax.friction.static_nm(w), rel=1e-5)
    ax = plant(**{"axes.ra.friction.preload": preload})  # Stribeck region: PI-held 15″/s
    pi_run(ax, 15.0, 1200)
    w = ax.axis_rate_rad_s
    assert w * ARCSEC_PER_RAD == pytest.approx(15.0, abs=1e-3)
    s = ax.friction
    expect = s.tc_pos_nm + (s.ts_nm - s.tc_pos_nm) * math.exp(-((w / s.omega_s_rad_s) ** s.delta)) \
        + s.sigma2_pos_nm_s_rad * w
    assert sum(ax.gear_torque_nm) == pytest.approx(expect, rel=1e-4)


def test_high_preload_tracking_exceeds_current_rating():
    """Proportional preload law (p = 0.20, Table 1) at high preload: tracking needs ≈14.6 A (15.7 A with
    p = 0.25), reported over the 6 A rating."""
    ax = plant(**{"axes.ra.friction.preload": "high"})
    pi_run(ax, 15.0, 1200)
    assert ax.axis_rate_arcsec_s == pytest.approx(15.0, abs=0.01)
    ia, ib = ax.motor_current_a
    assert ia == pytest.approx(14.6, abs=0.3)
    assert ia - ib == pytest.approx(sum(ax.gear_torque_nm) / (0.35 * ax.params.gear.ratio), rel=1e-3)
    assert ax.peak_current_a[0] > 6.0 and ax.current_over_rating_us[0] > 1_000_000


def test_deterministic():
    """Same inputs, same state to the last bit."""
    states = []
    for _ in range(2):
        ax = plant()
        pi_run(ax, 600.0, 300, kp=5e-5, ki=5e-6)
        states.append(ax.state())
    assert states[0] == states[1]


def test_advance_to_rejects_the_past_and_splits_substeps():
    """advance_to never goes back; odd intervals end exactly at t_us."""
    ax = plant()
    ax.advance_to(1_234)
    assert ax.now_us == 1_234
    with pytest.raises(ValueError):
        ax.advance_to(1_000)
    with pytest.raises(ValueError):
        ax.set_duties(float("nan"), 0.0)


def test_rigid_model_agrees_at_steady_state():
    """The rigid drive model reaches the same steady rate as the twin-train model."""
    rates = []
    for model in ("twin_train", "rigid"):
        ax = plant(**{"axes.ra.drive_model": model})
        ax.set_duties(0.5, 0.125)
        ax.advance_to(3_000_000)
        rates.append(ax.axis_rate_arcsec_s)
    assert rates[0] == pytest.approx(rates[1], rel=1e-3)


def test_effects_map_onto_the_plant():
    """Additive effects load the axis; asymmetric friction, presliding, backlash set model parameters."""
    imbalance = {"kind": "gravity_imbalance", "amplitude_nm": 50.0, "phase_rad": math.pi / 2}
    rates = []
    for effects in ([], [imbalance]):
        ax = plant(**{"axes.ra.effects": effects})
        ax.set_duties(0.5, 0.125)
        ax.advance_to(3_000_000)
        rates.append(ax.axis_rate_rad_s)
        if effects:
            load = 50.0 * math.sin(ax.axis_angle_rad + math.pi / 2)
            assert sum(ax.gear_torque_nm) == pytest.approx(
                ax.friction.static_nm(ax.axis_rate_rad_s) + load, rel=1e-4)
    assert rates[1] < rates[0]
    ax = plant(**{"axes.ra.effects": [
        {"kind": "asymmetric_friction", "viscous_pos_nm_s_rad": 7000.0, "viscous_neg_nm_s_rad": 6000.0,
         "coulomb_pos_nm": 240.0, "coulomb_neg_nm": 210.0},
        {"kind": "presliding", "sigma0_nm_rad": 2e8, "sigma1_nm_s_rad": 1e5},
        {"kind": "backlash", "width_rad": 5e-4},
    ]})
    f = ax.friction
    assert (f.tc_pos_nm, f.tc_neg_nm, f.sigma2_pos_nm_s_rad, f.sigma2_neg_nm_s_rad) == (240, 210, 7000, 6000)
    assert (f.sigma0_nm_rad, f.sigma1_nm_s_rad) == (2e8, 1e5)
    assert ax.backlash_rad == 5e-4
    extra = AxisPlant(load_parameters().ra, effects=[build_effect(imbalance)])
    assert len(extra._additive) == 1


def test_asymmetric_friction_fields_in_the_file():
    """tc_pos/tc_neg/sigma2_pos/sigma2_neg fields in the friction section make friction direction-dependent."""
    ax = plant(**{"axes.ra.friction.tc_neg_nm": 300.0, "axes.ra.friction.sigma2_pos_nm_s_rad": 8000.0})
    f = ax.friction
    assert f.tc_pos_nm == 229.0 and f.tc_neg_nm == 300.0
    assert f.sigma2_pos_nm_s_rad == 8000.0 and f.sigma2_neg_nm_s_rad == 6700.0
    assert f.static_nm(-1e-2) == pytest.approx(-300.0 - 67.0, rel=1e-6)


def test_perfect_switch_turns_off_imperfections():
    """perfect: no backlash, friction σ2·ω only, no effects; steady state = duty balance exactly."""
    ax = plant(**{"perfect": True, "axes.ra.effects": [{"kind": "gravity_imbalance", "amplitude_nm": 50.0,
                                                         "phase_rad": 0.0}]})
    assert ax.backlash_rad == 0.0 and ax.effects == []
    ax.set_duties(0.1, 0.0)
    ax.advance_to(200_000)
    assert ax.axis_rate_rad_s > 0  # no stiction: any duty moves it
    ax.advance_to(10_000_000)
    w = ax.axis_rate_rad_s
    assert sum(ax.gear_torque_nm) == pytest.approx(6700.0 * w, rel=1e-4)


def test_mesh_torque_law():
    """mesh_torque_nm (the law the substep inlines): zero in the dead zone, spring plus damper
    outside it, and the teeth only push."""
    from plant.axis import AxisPlant

    m = AxisPlant.mesh_torque_nm
    hb, kt, ct = 1e-3, 1e6, 1e3
    assert m(0.5e-3, 5.0, kt, ct, hb) == 0.0 and m(-0.9e-3, -5.0, kt, ct, hb) == 0.0
    assert m(3e-3, 0.5, kt, ct, hb) == pytest.approx(kt * 2e-3 + ct * 0.5)
    assert m(-3e-3, -0.5, kt, ct, hb) == pytest.approx(-(kt * 2e-3 + ct * 0.5))
    assert m(2e-3, -1e4, kt, ct, hb) == 0.0 and m(-2e-3, 1e4, kt, ct, hb) == 0.0
