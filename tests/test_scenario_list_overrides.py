"""Scenario plant overrides take lists: a scenario adds plant effects without copying the parameter file."""

from __future__ import annotations

import math

import pytest

from host.network import resolve_parameters
from host.scenario import ScenarioError, parse_scenario

BASE = """
name: list-override
plant:
  overrides:
    axes.ra.effects:
      - {kind: position_periodic, period_rad: 0.01, amplitude_nm: 5.0, phase_rad: 0.2}
      - {kind: time_periodic, frequency_hz: 0.5, amplitude_nm: 2.0, phase_rad: 0.0}
    axes.ra.gear_disturbance.motor_twice.amplitude_nm: 3.5
segments:
  - {name: track, axis: ra, mode: track, duration_s: 1}
"""


def test_list_override_adds_effects():
    """A list under plant.overrides becomes the axis's effects; leaves still override as before."""
    sc = parse_scenario(BASE, "s.yaml")
    p = resolve_parameters(sc)
    kinds = [e["kind"] for e in p.axes["ra"].effects]
    assert kinds == ["position_periodic", "time_periodic"]
    assert p.axes["dec"].effects == ()
    assert p.axes["ra"].gear_disturbance["motor_twice"]["amplitude_nm"] == 3.5
    from plant.axis import AxisPlant

    ax = AxisPlant(p.axes["ra"])
    assert sum(e.torque_nm(0.0025, 0.0, 0.0) for e in ax.effects) == pytest.approx(
        5.0 * math.sin(2 * math.pi * 0.25 + 0.2) + 0.0)
    assert [(ln["line"], ln["follows"]) for ln in ax.gear_lines if ln["line"] == "motor_twice"] == [
        ("motor_twice", "train_a"), ("motor_twice", "train_b")]


def test_bad_effect_in_list_names_the_override():
    bad = BASE.replace("kind: time_periodic", "kind: nonsense")
    with pytest.raises(ScenarioError) as e:
        parse_scenario(bad, "s.yaml")
    assert "plant.overrides.axes.ra.effects" in str(e.value) and "nonsense" in str(e.value)
