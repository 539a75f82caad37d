"""The effects library (plant/effects.py): construction, torque laws, specs and errors."""

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from plant.effects import EFFECT_KINDS, build_effect, total_additive_torque_nm

SPECS = {
    "asymmetric_friction": {"viscous_pos_nm_s_rad": 4.0, "viscous_neg_nm_s_rad": 6.0, "coulomb_pos_nm": 2.0, "coulomb_neg_nm": 3.0},
    "position_periodic": {"period_rad": 0.1, "amplitude_nm": 0.5, "phase_rad": 0.3},
    "gravity_imbalance": {"amplitude_nm": 1.5, "phase_rad": -0.2},
    "presliding": {"sigma0_nm_rad": 1e5, "sigma1_nm_s_rad": 10.0},
    "backlash": {"width_rad": 0.004},
    "time_periodic": {"frequency_hz": 7.3, "amplitude_nm": 0.3, "phase_rad": 1.0},
}


def test_all_six_kinds_registered():
    """The registry holds exactly the six kinds of the issue."""
    assert set(EFFECT_KINDS) == set(SPECS)


@pytest.mark.parametrize("kind", sorted(SPECS))
def test_spec_round_trip(kind):
    """build_effect(e.to_spec()) rebuilds an equal effect."""
    e = build_effect({"kind": kind, **SPECS[kind]})
    assert e.kind == kind
    assert build_effect(e.to_spec()) == e


def test_unknown_kind_names_valid_kinds():
    """An unknown kind raises ValueError listing the valid kinds."""
    with pytest.raises(ValueError, match="valid kinds.*position_periodic"):
        build_effect({"kind": "cogging"})


def test_unknown_and_missing_parameters():
    """Unknown or missing parameters raise ValueError naming the kind and its parameters."""
    with pytest.raises(ValueError, match="'backlash'.*unknown.*width_rad"):
        build_effect({"kind": "backlash", "width_deg": 1.0})
    with pytest.raises(ValueError, match="'time_periodic'.*missing.*frequency_hz"):
        build_effect({"kind": "time_periodic", "amplitude_nm": 1.0, "phase_rad": 0.0})
    with pytest.raises(ValueError, match="period_rad.*> 0"):
        build_effect({"kind": "position_periodic", "period_rad": 0.0, "amplitude_nm": 1.0, "phase_rad": 0.0})
    with pytest.raises(ValueError, match="finite"):
        build_effect({"kind": "gravity_imbalance", "amplitude_nm": float("nan"), "phase_rad": 0.0})


def test_torque_laws():
    """Each additive law is the documented formula; stateful kinds return 0."""
    pp = build_effect({"kind": "position_periodic", **SPECS["position_periodic"]})
    assert pp.torque_nm(0.025, 0.0, 0.0) == pytest.approx(0.5 * math.sin(2 * math.pi * 0.25 + 0.3))
    g = build_effect({"kind": "gravity_imbalance", **SPECS["gravity_imbalance"]})
    assert g.torque_nm(1.0, 0.0, 0.0) == pytest.approx(1.5 * math.sin(1.0 - 0.2))
    tp = build_effect({"kind": "time_periodic", **SPECS["time_periodic"]})
    assert tp.torque_nm(0.0, 0.0, 0.1) == pytest.approx(0.3 * math.sin(2 * math.pi * 0.73 + 1.0))
    af = build_effect({"kind": "asymmetric_friction", **SPECS["asymmetric_friction"]})
    assert af.torque_nm(0.0, 2.0, 0.0) == pytest.approx(4.0 * 2 + 2.0)
    assert af.torque_nm(0.0, -2.0, 0.0) == pytest.approx(-6.0 * 2 - 3.0)
    for kind in ("presliding", "backlash"):
        assert build_effect({"kind": kind, **SPECS[kind]}).torque_nm(1.0, 1.0, 1.0) == 0.0


@given(theta=st.floats(-10, 10), omega=st.floats(-5, 5), t=st.floats(0, 100))
def test_additive_sum_skips_mapped_kinds(theta, omega, t):
    """total_additive_torque_nm sums only the additive kinds."""
    effects = [build_effect({"kind": k, **v}) for k, v in SPECS.items()]
    expected = sum(e.torque_nm(theta, omega, t) for e in effects if e.kind in ("position_periodic", "gravity_imbalance", "time_periodic"))
    assert total_additive_torque_nm(effects, theta, omega, t) == pytest.approx(expected)
