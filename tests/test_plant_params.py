"""Parameter file: loading, overrides, errors, round trip."""

from __future__ import annotations

import dataclasses
import math

import pytest
import yaml

from plant.params import DEFAULT_PATH, ParameterError, dump_parameters, load_parameters


def test_every_leaf_has_value_unit_source():
    """Every leaf of the shipped file is {value, unit, source} with a non-empty source."""
    tree = yaml.safe_load(DEFAULT_PATH.read_text())

    def walk(node, path):
        if isinstance(node, dict) and "value" in node:
            assert set(node) == {"value", "unit", "source"}, path
            assert str(node["source"]).strip(), path
            return 1
        if isinstance(node, list):
            return 0
        return sum(walk(v, f"{path}.{k}") for k, v in node.items())

    assert walk(tree, "") > 60


def test_paper_numbers_in_si():
    """Paper values arrive in SI: J, stiffness, gear ratio, Table 2, 6 A, 24 V, 0.1 Ω."""
    p = load_parameters()
    ra, dec = p.ra, p.dec
    assert ra.inertia_kg_m2 == 1760.0 and dec.inertia_kg_m2 == 579.0
    assert ra.gear.stiffness_nm_rad == 3.08e6 and dec.gear.stiffness_nm_rad == 2.46e6
    assert ra.gear.ratio == pytest.approx((113 / 27) * (123 / 21) * (250 / 17))
    assert ra.gear.ratio == pytest.approx(360.489, abs=1e-3)
    assert ra.gear.backlash_rad == pytest.approx(math.radians(21.0) / 360.489, rel=1e-5)
    assert ra.friction.low.tc_nm == 229 and ra.friction.high.ts_nm == 1490
    assert ra.friction.active is ra.friction.low
    assert ra.motor.rated_current_a == 6.0 and ra.motor.supply_v == 24.0 and ra.motor.shunt_ohm == 0.1
    assert ra.drive.preload_law == "proportional" and ra.drive.counter_fraction == 0.20
    assert dec.friction.low.tc_nm == pytest.approx(229 * 186 / 791, rel=1e-3)
    assert p.focus.metres_per_halfstep == pytest.approx(6.25e-6)


def test_dotted_override_sets_value():
    """A dotted override sets the leaf value; the preload selector switches the active set."""
    p = load_parameters(overrides={"axes.ra.friction.sigma0_nm_rad": 2e8, "axes.ra.friction.preload": "high",
                                   "perfect": True})
    assert p.ra.friction.sigma0_nm_rad == 2e8
    assert p.ra.friction.active.ts_nm == 1490
    assert p.perfect and p.ra.perfect and p.dec.perfect


def test_unknown_path_names_path_and_valid_keys():
    """A wrong override path raises ParameterError naming it and the valid keys."""
    with pytest.raises(ParameterError) as exc:
        load_parameters(overrides={"axes.ra.friction.sigma9_nm_rad": 1.0})
    msg = str(exc.value)
    assert "axes.ra.friction.sigma9_nm_rad" in msg and "sigma0_nm_rad" in msg and "preload" in msg
    with pytest.raises(ParameterError, match="valid keys"):
        load_parameters(overrides={"axes.ra.friction": 1.0})
    with pytest.raises(ParameterError):
        load_parameters(overrides={"axes.ra.friction.preload": "medium"})
    with pytest.raises(ParameterError):
        load_parameters(overrides={"axes.ra.motor.resistance_ohm": -1.0})


def test_effects_override_and_validation():
    """Effects are a list override, validated at load time."""
    spec = {"kind": "gravity_imbalance", "amplitude_nm": 10.0, "phase_rad": 0.0}
    p = load_parameters(overrides={"axes.ra.effects": [spec]})
    assert p.ra.effects == (spec,)
    with pytest.raises(ParameterError, match="effects"):
        load_parameters(overrides={"axes.ra.effects": [{"kind": "nonsense"}]})


def test_dump_round_trip(tmp_path):
    """dump_parameters writes the same format; replace() edits and effects survive a reload."""
    p = load_parameters(overrides={"axes.dec.friction.preload": "high"})
    ra = dataclasses.replace(p.ra, friction=dataclasses.replace(p.ra.friction, sigma0_nm_rad=3e8),
                             effects=({"kind": "backlash", "width_rad": 1e-4},))
    p2 = dataclasses.replace(p, axes={**p.axes, "ra": ra})
    out = tmp_path / "cal.yaml"
    dump_parameters(p2, out)
    q = load_parameters(out)
    assert q.ra.friction.sigma0_nm_rad == 3e8
    assert q.dec.friction.preload == "high"
    assert q.ra.effects == ({"kind": "backlash", "width_rad": 1e-4},)
    assert q.ra.gear == p.ra.gear and q.focus == p.focus
    tree = yaml.safe_load(out.read_text())
    assert "source" in tree["axes"]["ra"]["friction"]["sigma0_nm_rad"]
