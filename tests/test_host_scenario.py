"""Scenario files are validated on load; errors name the file, the line and the key."""

from pathlib import Path

import pytest

from host.scenario import resolve_parameters
from host.scenario import ScenarioError, load_scenario, parse_scenario

SCENARIOS = sorted((Path(__file__).resolve().parent.parent / "scenarios").glob("*.yaml"))

GOOD = """\
name: t
segments:
  - name: track
    axis: ra
    mode: track
    duration_s: 10
    settle_s: 2
"""


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.name)
def test_every_shipped_scenario_validates(path):
    """Every scenario in scenarios/ loads and its plant parameters resolve."""
    sc = load_scenario(path)
    assert sc.segments
    resolve_parameters(sc)


def test_required_scenarios_exist():
    """The scenarios issue 2 asks for are shipped."""
    names = {p.name for p in SCENARIOS}
    assert {"tracking-low-preload.yaml", "tracking-high-preload.yaml", "high-speed.yaml",
            "pointing-sequence.yaml", "open-loop.yaml"} <= names


def test_unknown_key_names_file_line_and_key():
    """A misspelt key in a segment is reported with its line and dotted path."""
    text = GOOD.replace("    settle_s: 2", "    setle_s: 2")
    with pytest.raises(ScenarioError) as e:
        parse_scenario(text, "my.yaml")
    msg = str(e.value)
    assert msg.startswith("my.yaml:7: segments[0].setle_s: unknown key")
    assert "settle_s" in msg  # the valid keys are listed
    assert e.value.line == 7


def test_bad_value_names_line_and_expected_values():
    """A mode that does not exist is rejected with the allowed modes."""
    with pytest.raises(ScenarioError) as e:
        parse_scenario(GOOD.replace("mode: track", "mode: tracking"), "s.yaml")
    assert e.value.line == 5 and e.value.key == "segments[0].mode"
    assert "'track'" in str(e.value) and "tracking" in str(e.value)


def test_unknown_top_level_key():
    """An unknown top-level key stops the load before anything runs."""
    with pytest.raises(ScenarioError) as e:
        parse_scenario("name: t\nsegmnts: []\n", "s.yaml")
    assert e.value.line == 2 and e.value.key == "segmnts"


def test_yaml_syntax_error_has_line():
    """Broken YAML is reported with the line of the syntax error."""
    with pytest.raises(ScenarioError) as e:
        parse_scenario("name: t\nsegments: [\n  - {name: a\n", "s.yaml")
    assert "YAML syntax" in str(e.value) and e.value.line is not None


def test_velocity_needs_a_rate():
    """mode velocity without rate_arcsec_s is refused (and a preset with one)."""
    with pytest.raises(ScenarioError, match="rate_arcsec_s"):
        parse_scenario(GOOD.replace("mode: track", "mode: velocity"), "s.yaml")
    with pytest.raises(ScenarioError, match="preset"):
        parse_scenario(GOOD.replace("mode: track", "mode: track\n    rate_arcsec_s: 3"), "s.yaml")


def test_negative_duration_rejected():
    """Durations must be positive."""
    with pytest.raises(ScenarioError) as e:
        parse_scenario(GOOD.replace("duration_s: 10", "duration_s: -1"), "s.yaml")
    assert e.value.key == "segments[0].duration_s" and e.value.line == 6


def test_unknown_plant_override_is_a_scenario_error(tmp_path):
    """A plant override naming a parameter that does not exist fails at load (before anything
    runs) with the file, the override's line and the valid keys."""
    p = tmp_path / "s.yaml"
    p.write_text(GOOD + "plant:\n  preload: low\n  overrides:\n    axes.ra.friction.sigma9_nm_rad: 1.0\n")
    with pytest.raises(ScenarioError) as e:
        load_scenario(p)
    assert e.value.line == 11 and e.value.key == "plant.overrides.axes.ra.friction.sigma9_nm_rad"
    assert f"{p}:11:" in str(e.value) and "valid keys" in str(e.value)


def test_missing_parameter_file_is_a_scenario_error(tmp_path):
    p = tmp_path / "s.yaml"
    p.write_text(GOOD + "plant:\n  parameter_file: nothere.yaml\n")
    with pytest.raises(ScenarioError) as e:
        load_scenario(p)
    assert e.value.line == 9 and e.value.key == "plant.parameter_file" and "nothere.yaml" in str(e.value)


def test_missing_file():
    """A scenario path that does not exist gives a one-line error naming it."""
    with pytest.raises(ScenarioError, match="nope.yaml"):
        load_scenario("nope.yaml")
