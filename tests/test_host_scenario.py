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


# ------------------------------------------------------------------ issue 11: nothing that can fail mid-run passes
_BASE = "name: t\nsegments:\n  - {name: a, axis: ra, mode: track, duration_s: 1}\n"


@pytest.mark.parametrize("extra,where", [
    ("controller: {ra: {kp: .inf}}\n", "controller.ra.kp"),
    ("faults: [{at_s: .inf, kind: board_reset, board: ra-axis}]\n", "faults[0].at_s"),
    ("faults: [{at_s: 0.5, kind: endat_bit_flip, board: ra-reader, bit: 63}]\n", "faults[0].bit"),
    ("faults: [{at_s: 0.5, kind: endat_bit_flip, board: ra-axis}]\n", "faults[0]"),
    ("faults: [{at_s: 5, kind: board_reset, board: ra-axis}]\n", "after the end of the run"),
    ("faults: [{at_s: 0.5, kind: host_loss, board: ra-axis}]\n", "faults[0]"),
    ("faults: [{at_s: 0.5, kind: bus_off}]\n", "needs board"),
    ("faults: [{at_s: 0.5, kind: can_error, probability: 1.5}]\n", "faults[0].probability"),
    ("faults: [{at_s: 0.5, kind: can_error, ids: [2048]}]\n", "faults[0].ids"),
    ("bus: {interface: virtual}\nfaults: [{at_s: 0.5, kind: frame_loss}]\n", "bus.interface: sim"),
])
def test_validation_refuses_what_would_fail_mid_run(extra, where):
    """Non-finite numbers, faults after the end, bits outside the EnDat frame, faults aimed at the
    wrong board and bus faults off the emulated bus are refused at load, naming file and key."""
    with pytest.raises(ScenarioError) as e:
        parse_scenario(_BASE + extra, "s.yaml")
    msg = str(e.value)
    assert msg.startswith("s.yaml") and where in msg and "\n" not in msg


def test_rate_above_the_firmware_maximum_is_refused():
    """A VELOCITY segment faster than the firmware accepts (3°/s) is refused at load."""
    with pytest.raises(ScenarioError, match=r"segments\[0\]\.rate_arcsec_s"):
        parse_scenario("name: t\nsegments:\n  - {name: a, axis: ra, mode: velocity, rate_arcsec_s: 10801, "
                       "duration_s: 1}\n", "s.yaml")


def test_yaml_alias_bomb_is_refused_at_once():
    """An alias bomb (the 'billion laughs') is refused before it expands, on one line."""
    bomb = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
        f"{c}: &{c} [*{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}]\n"
        for p, c in zip("abcdefghi", "bcdefghij")) + _BASE
    with pytest.raises(ScenarioError, match="aliases") as e:
        parse_scenario(bomb, "bomb.yaml")
    assert "\n" not in str(e.value)


def test_oversized_scenarios_are_refused():
    """More segments or bytes than the documented limits are refused before validation."""
    from host.scenario import MAX_SCENARIO_BYTES, MAX_SEGMENTS

    segs = "".join(f"  - {{name: s{i}, axis: ra, mode: track, duration_s: 1}}\n" for i in range(MAX_SEGMENTS + 1))
    with pytest.raises(ScenarioError):
        parse_scenario("name: t\nsegments:\n" + segs, "big.yaml")
    with pytest.raises(ScenarioError, match="larger than"):
        parse_scenario(_BASE + "#" * MAX_SCENARIO_BYTES, "big.yaml")


def test_bus_fault_kinds_run_from_a_scenario(tmp_path):
    """can_error, frame_loss, bus_off, host_loss and reader_loss, given in a scenario, reach the
    bus model and boards: error frames counted, the board off the bus, the host silent."""
    from host.runner import run_scenario

    text = _BASE.replace("duration_s: 1", "duration_s: 1.5") + (
        "faults:\n"
        "  - {at_s: 0.2, kind: can_error, ids: [0x181], count: 3}\n"
        "  - {at_s: 0.3, kind: frame_loss, board: dec-axis, duration_s: 0.1}\n"
        "  - {at_s: 0.4, kind: bus_off, board: focus}\n"
        "  - {at_s: 0.5, kind: reader_loss, board: dec-reader}\n"
        "  - {at_s: 1.0, kind: host_loss, duration_s: 0.2}\n")
    res = run_scenario(parse_scenario(text, str(tmp_path / "s.yaml")), tmp_path / "out", plots=False)
    errors = (tmp_path / "out" / "errors.log").read_text()
    for kind in ("can_error", "frame_loss", "bus_off", "reader_loss", "host_loss"):
        assert f"injected-fault {kind}" in errors or kind in errors, kind
    assert res.report["bus_stats"].get("error_frames", 0) >= 3


def test_a_removed_board_is_logged_lost_and_reported_lost(tmp_path):
    """A board that loses power is logged at once (≤ timeout + check period) in errors.log as
    heartbeat-lost, and the report shows it LOST, not OPERATIONAL (issue 11, defect 3)."""
    from host.client import HostClient
    from host.runner import run_scenario

    text = _BASE.replace("duration_s: 1", "duration_s: 5") + "faults: [{at_s: 1.0, kind: reader_loss, board: ra-reader}]\n"
    res = run_scenario(parse_scenario(text, str(tmp_path / "s.yaml")), tmp_path / "out", plots=False)
    assert res.report["boards"]["ra-reader"]["state"] == "LOST"
    assert res.report["boards"]["dec-reader"]["state"] != "LOST"
    lines = [ln for ln in (tmp_path / "out" / "errors.log").read_text().splitlines() if "heartbeat-lost" in ln]
    assert len(lines) == 1 and "ra-reader" in lines[0]
    t_s = float(lines[0].split()[0])
    # the end of the power-on (faults' at_s counts from it): read from status.log, since through
    # the USB gateway its SDO reads take longer than BOOT_US + POWER_ON_US (docs/usb-gateway.md)
    status = (tmp_path / "out" / "status.log").read_text().splitlines()
    boot_s = float(next(ln for ln in status if " health-check " in ln).split()[0])
    assert boot_s >= (HostClient.BOOT_US + HostClient.POWER_ON_US) / 1e6
    # the last heartbeat came ≤ 1 s before the fault; lost after the timeout, seen within one check
    assert t_s <= boot_s + 1.0 + (HostClient.HEARTBEAT_TIMEOUT_US + HostClient.HEARTBEAT_CHECK_US) / 1e6
