"""Specification of the axis control law: incremental PI, anti-windup, drive laws, tuning rule."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from boards.control import DRIVE_LAWS, IncrementalPI, drive_proportional
from boards.tuning import pi_gains_from_model

errors = st.floats(min_value=-1e4, max_value=1e4, allow_nan=False)
gains = st.floats(min_value=0.0, max_value=1e-2, allow_nan=False)
fractions = st.floats(min_value=0.10, max_value=0.25)

RA_MODEL = dict(inertia_kg_m2=1760.0, sigma2_nm_s_rad=6700.0, gear_ratio=360.489, r_ohm=1.2,
                l_h=1.5e-3, k_nm_a=0.35, rotor_inertia_kg_m2=0.0, counter_fraction=0.25,
                supply_v=24.0, tick_us=5000)


@given(kp=gains, ki=gains, e_prev=errors, e=errors, u0=st.floats(-0.5, 0.5))
def test_increment_is_kp_delta_e_plus_ki_e_when_not_clamped(kp, ki, e_prev, e, u0):
    """dU equals Kp·(E_k − E_{k−1}) + Ki·E_k exactly whenever U stays inside the limits."""
    pi = IncrementalPI(kp, ki, u_max=1.0)
    pi.force(u0, e_prev)
    du = kp * (e - e_prev) + ki * e
    u = pi.update(e)
    if abs(u0 + du) < 1.0:
        assert u == u0 + du
        assert not pi.saturated
    else:
        assert abs(u) == 1.0 and pi.saturated


@given(kp=gains, ki=st.floats(1e-6, 1e-2), seq=st.lists(errors, min_size=1, max_size=60),
       p=fractions, law=st.sampled_from(sorted(DRIVE_LAWS)), u_max=st.floats(0.1, 1.0))
def test_effort_and_duties_stay_within_limits(kp, ki, seq, p, law, u_max):
    """For any error sequence U stays in [−u_max, u_max] and both duties in [0, 1]."""
    pi = IncrementalPI(kp, ki, u_max=u_max)
    for e in seq:
        u = pi.update(e)
        assert -u_max <= u <= u_max
        a, b = DRIVE_LAWS[law](u, p)
        assert 0.0 <= a <= 1.0 and 0.0 <= b <= 1.0


@given(kp=gains, ki=st.floats(1e-6, 1e-2), n_sat=st.integers(1, 200),
       e_pos=st.floats(1.0, 1e4), e_neg=st.floats(-1e4, -1e-3))
def test_no_windup_effort_leaves_limit_when_error_changes_sign(kp, ki, n_sat, e_pos, e_neg):
    """After any time at the upper limit, U drops below it on the first tick with negative error."""
    pi = IncrementalPI(kp, ki, u_max=1.0)
    pi.force(1.0, e_pos)            # at the limit, error positive
    for _ in range(n_sat):
        pi.update(e_pos)
        assert pi.u == 1.0
    u = pi.update(e_neg)
    assert u < 1.0
    assert u == pytest.approx(max(-1.0, 1.0 + kp * (e_neg - e_pos) + ki * e_neg))


@given(u=st.floats(-1.0, 1.0), p=fractions)
def test_proportional_law_forward_gets_u_reverse_gets_p_u(u, p):
    """Paper §3.3: forward motor |U|, reverse motor p·|U|; motor A pushes +, motor B pushes −."""
    a, b = drive_proportional(u, p)
    fwd, rev = (a, b) if u >= 0 else (b, a)
    assert fwd == abs(u)
    assert rev == p * abs(u)
    assert (a - b) == pytest.approx((1 - p) * u)


def test_tuning_rule_numbers_follow_simc_half_rule():
    """Kc = τ1'/(k(τc+θ')), τI = min(τ1', 4(τc+θ')), Ki = Kc·Δt/τI with θ = Δt/2 + Δt/2."""
    g = pi_gains_from_model(**RA_MODEL)
    assert g.theta_s == 0.005
    assert pi_gains_from_model(**RA_MODEL, include_measurement_lag=False).theta_s == 0.0025
    assert g.tau1_eff_s == pytest.approx(g.tau1_s + g.tau2_s / 2)
    assert g.theta_eff_s == pytest.approx(g.theta_s + g.tau2_s / 2)
    assert g.kc == pytest.approx(g.tau1_eff_s / (g.k * 2 * g.theta_eff_s))
    assert g.tau_i_s == pytest.approx(min(g.tau1_eff_s, 8 * g.theta_eff_s))
    assert g.ki == pytest.approx(g.kc * 0.005 / g.tau_i_s)
    # the eq. 6 poles: mechanical ~0.09 s, electrical ~L/R
    assert 0.05 < g.tau1_s < 0.2 and g.tau2_s == pytest.approx(1.5e-3 / 1.2, rel=0.05)


def _closed_loop_poles(g, model):
    """Poles of eq. 6 (ZOH, Δt) + per-tick QEI rate measurement + incremental PI (z-domain)."""
    from scipy.signal import cont2discrete
    N = model["gear_ratio"]
    jr = model["inertia_kg_m2"] / N**2 + model["rotor_inertia_kg_m2"]
    s2r = model["sigma2_nm_s_rad"] / N**2
    R, L, K = model["r_ohm"], model["l_h"], model["k_nm_a"]
    gain_in = (1 - model["counter_fraction"]) * model["supply_v"]
    out = 206264.806 / N                                  # motor rad -> axis arcsec
    A = np.array([[-R / L, -K / L, 0], [K / jr, -s2r / jr, 0], [0, 1, 0]])   # i, ω, θ (motor)
    B = np.array([[gain_in / L], [0], [0]])
    dt = model["tick_us"] * 1e-6
    Ad, Bd, *_ = cont2discrete((A, B, np.eye(3), np.zeros((3, 1))), dt, method="zoh")
    # state z_k = [i_k, ω_k, d_k, u_{k-1}, e_{k-1}], d_k = θ_k − θ_{k−1} (the QEI count difference)
    # y_k = out·d_k/dt; e_k = −y_k; u_k = u_{k−1} + kp (e_k − e_{k−1}) + ki e_k
    e_row = np.array([0, 0, -out / dt, 0, 0])
    u_row = (g.kp + g.ki) * e_row + np.array([0, 0, 0, 1.0, -g.kp])
    M = np.zeros((5, 5))
    M[0:2, 0:2] = Ad[0:2, 0:2]
    M[0:2, :] += Bd[0:2] @ u_row[None, :]
    M[2, 0:2] = Ad[2, 0:2]
    M[2, :] += Bd[2, 0] * u_row
    M[3, :] = u_row
    M[4, :] = e_row
    return np.linalg.eigvals(M)


@pytest.mark.parametrize("p", [0.10, 0.25])
@pytest.mark.parametrize("sigma2", [6700.0, 11300.0])
def test_tuned_gains_make_the_linear_loop_stable(p, sigma2):
    """The discrete loop (eq. 6, ZOH, per-tick QEI rate, incremental PI) has all poles inside |z|<1."""
    model = dict(RA_MODEL, counter_fraction=p, sigma2_nm_s_rad=sigma2)
    g = pi_gains_from_model(**model)
    poles = _closed_loop_poles(g, model)
    assert max(abs(poles)) < 0.999


def _step_peak_and_final(g):
    """Closed-loop 600″/s step of the linear eq. 6 model (fine Euler), per-tick QEI rate, PI."""
    N, R, L, K = 360.489, 1.2, 1.5e-3, 0.35
    jr, s2r = 1760 / N**2, 6700 / N**2
    i = w = th = 0.0
    pi = IncrementalPI(g.kp, g.ki, u_max=1.0)
    sp, th_prev, ys = 600.0, 0.0, []
    h = 1e-5
    for _ in range(400):                                    # 2 s
        y = (th - th_prev) * 206264.806 / N / 0.005
        th_prev = th
        u = pi.update(sp - y)
        v = 0.75 * 24 * u
        for _ in range(500):
            di = (v - R * i - K * w) / L
            dw = (K * i - s2r * w) / jr
            i += h * di; w += h * dw; th += h * w
        ys.append(y)
    return max(ys) / sp, float(np.mean(ys[-40:])) / sp


def test_tuned_gains_step_response_settles_without_large_overshoot():
    """Rate step of the linear loop with the tuned gains: overshoot < 30 %, no offset."""
    peak, final = _step_peak_and_final(pi_gains_from_model(**RA_MODEL))
    assert peak < 1.3
    assert final == pytest.approx(1.0, abs=0.01)


def test_paper_half_tick_dead_time_alone_overshoots_more():
    """With θ = Δt/2 only (measurement lag ignored) the same rule overshoots more than 50 %."""
    peak, _ = _step_peak_and_final(pi_gains_from_model(**RA_MODEL, include_measurement_lag=False))
    assert peak > 1.5


def test_tuning_rejects_nonphysical_input():
    """Non-positive resistance or p outside [0, 1) is a ValueError."""
    with pytest.raises(ValueError):
        pi_gains_from_model(**dict(RA_MODEL, r_ohm=0.0))
    with pytest.raises(ValueError):
        pi_gains_from_model(**dict(RA_MODEL, counter_fraction=1.0))
