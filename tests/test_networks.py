"""Networks by name (issue 12): ``network: basic | lab | full | [boards]`` chooses the boards that
are built, health-checked, logged and reported; on a network with tachometers and auxiliary
encoders the §5.2 maintenance quantities appear in sensor.log and the report."""

from __future__ import annotations

import json
import math

import pytest

import boards.registry as R
from bus import protocol as P
from host.logs import SENSOR_COLUMNS
from host.maintenance import sensor_columns
from host.runner import run_scenario
from host.scenario import ScenarioError, parse_scenario

PAPER_LAB_KINDS = ("axis_controller", "position_reader", "tachometer", "display", "usb_gateway")


def _sc(body: str, tmp_path, name="s.yaml"):
    return parse_scenario("name: n\n" + body, str(tmp_path / name))


def test_named_networks_are_derived_from_the_registry():
    """basic = today's five boards (+ the gateway once registered); lab = every instance of the
    paper's lab kinds (§3.4); full = every board of the registry; all in node order."""
    kinds = {n: s.kind for n, (s, _) in R.BOARDS.items()}
    assert [kinds[n] for n in R.NETWORKS["basic"] if kinds[n] != "usb_gateway"] == [
        "axis_controller", "axis_controller", "position_reader", "position_reader", "focus_controller"]
    assert R.NETWORKS["lab"] == tuple(n for n in R.BOARD_NAMES if kinds[n] in PAPER_LAB_KINDS)
    assert [kinds[n] for n in R.NETWORKS["lab"]].count("tachometer") == 4
    assert R.NETWORKS["full"] == R.BOARD_NAMES
    # an explicit list: node order, and the host's own node (the USB-HID gateway) is always on the bus
    assert R.network_boards(["ra-tach-2", "dec-axis", "ra-axis"]) == ("ra-axis", "dec-axis", "ra-tach-2", "gateway")
    assert len(R.NETWORKS["lab"]) == 10                                        # §3.4: "10 nodes"


@pytest.mark.parametrize("body,key,words", [
    ("network: bogus\n", "network", "unknown network 'bogus'; valid: basic, lab, full"),
    ("network: [ra-axis, dec-axis, nope]\n", "network", "unknown board 'nope'"),
    ("network: [ra-axis, dec-axis, ra-axis]\n", "network", "more than once: ra-axis"),
    ("network: [ra-axis, ra-tach-1]\n", "network", "missing dec-axis"),
    ("network: lab\nfaults: [{at_s: 0.1, kind: board_reset, board: focus}]\n", "", "'focus' is not on the network 'lab'"),
])
def test_bad_network_is_a_one_line_error_naming_file_and_key(tmp_path, body, key, words):
    """A bad network (or a fault on a board that is not on it) fails at load time, in one line
    naming the file, the key and what was expected."""
    with pytest.raises(ScenarioError) as e:
        _sc(body + "segments:\n  - {name: a, mode: stop, duration_s: 1}\n", tmp_path)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(str(tmp_path / "s.yaml")) and words in msg
    assert e.value.key == key or (not key and "faults[0]" in msg)


def test_basic_network_keeps_todays_logs_and_report(tmp_path):
    """The default network builds today's boards; sensor.log keeps today's columns and the report
    has no maintenance section."""
    sc = _sc("segments:\n  - {name: t, mode: track, duration_s: 0.5}\n", tmp_path)
    assert sc.network == "basic" and sensor_columns(sc.board_names) == ()
    res = run_scenario(sc, tmp_path / "out", plots=False)
    assert res.report["network"] == "basic" and list(res.report["nodes"]) == list(R.NETWORKS["basic"])
    assert "maintenance" not in res.report
    header = (tmp_path / "out" / "sensor.log").read_text().splitlines()[1]
    assert header == "# " + " ".join(SENSOR_COLUMNS)


def test_explicit_list_builds_checks_and_reports_only_those_boards(tmp_path):
    """An explicit list: only those boards are built, answer the health check and have report rows."""
    sc = _sc("network: [ra-axis, dec-axis, dec-tach-2]\nsegments:\n  - {name: s, axis: dec, mode: slew, duration_s: 1.5}\n",
             tmp_path)
    res = run_scenario(sc, tmp_path / "out", plots=False)
    rep = res.report
    # (+ the host's own node, the USB-HID gateway, on every network)
    assert rep["network"] == "custom" and list(rep["boards"]) == ["ra-axis", "dec-axis", "dec-tach-2", "gateway"]
    assert all(b["state"] == "OPERATIONAL" for n, b in rep["boards"].items() if n != "gateway")
    assert list(rep["maintenance"]["motors"]) == ["dec_b"]
    status = (tmp_path / "out" / "status.log").read_text()
    assert "health-check ok" in status and "ra-reader" not in status
    assert P.frame_name(0x189) in rep["bus_stats"]["frames_by_id"]


@pytest.fixture(scope="module")
def full_run(tmp_path_factory):
    """A short slew + reverse + track on the full network (≈ 4 s simulated)."""
    out = tmp_path_factory.mktemp("full")
    sc = parse_scenario(
        "name: full-short\nseed: 2\nnetwork: full\nsegments:\n"
        "  - {name: slew, axis: both, mode: slew, direction: 1, duration_s: 2.5, settle_s: 1}\n"
        "  - {name: back, axis: both, mode: set, direction: -1, duration_s: 1.5, settle_s: 0.8}\n"
        "  - {name: track, axis: ra, mode: track, duration_s: 1.5}\n", str(out / "s.yaml"))
    res = run_scenario(sc, out / "run", plots=False)
    return sc, res, out / "run"


def test_full_network_report_lists_every_node_and_the_maintenance_quantities(full_run):
    """report.json and report.md list every registry board with its node, and a maintenance
    section with each motor's tachometer and each axis's auxiliary-vs-main difference."""
    sc, res, out = full_run
    rep = json.loads((out / "report.json").read_text())
    assert rep["network"] == "full" and rep["nodes"] == {n: int(i.node_id) for n, (_, i) in R.BOARDS.items()}
    assert list(rep["boards"]) == list(R.BOARD_NAMES)
    assert all(b["state"] == "OPERATIONAL" for n, b in rep["boards"].items() if n != "gateway")   # the gateway: no NMT
    m = rep["maintenance"]
    assert list(m["motors"]) == ["ra_a", "ra_b", "dec_a", "dec_b"]
    assert all(v["frames"] > 500 and v["peak_current_a"] > 0 for v in m["motors"].values())
    assert set(m["aux_minus_main_arcsec"]) == {"ra", "dec"}
    md = (out / "report.md").read_text()
    assert "## Maintenance (paper §5.2)" in md and "ra-tach-1 (0x06)" in md and "dec-aux (0x0B)" in md


def test_gear_reduction_from_frames_matches_the_plant_while_slewing(full_run):
    """At the steady 2°/s slew the host's motor-turns / axis-turns (from TACH_STATUS and
    AXIS_STATUS counts) is the plant's gear ratio (360.489, paper §2.2) within 0.05 %, for all
    four motors; per-segment values are given for the segment's own axis only."""
    sc, res, _ = full_run
    seg = {s["name"]: s for s in res.report["segments"]}
    n = res.report["maintenance"]["nominal_gear_reduction"]
    for axis in ("ra", "dec"):
        red = seg[f"slew/{axis}"]["gear_reduction"]
        assert set(red) == {f"{axis}_a", f"{axis}_b"}
        for v in red.values():
            assert abs(v - n[axis]) / n[axis] < 5e-4


def test_aux_minus_main_within_the_encoder_accuracy(full_run):
    """The auxiliary-vs-main difference the host computed (at ≤ 100″/s) stays within the A25S's
    ±15″ at the encoder shaft ÷ 10.8, plus one auxiliary count (0.9155″) and one main count."""
    sc, res, out = full_run
    bound = 15 / 10.8 + 1_296_000 / (2 ** 17 * 10.8) + 1_296_000 / 2 ** 29
    aux = res.report["maintenance"]["aux_minus_main_arcsec"]
    assert aux["ra"]["compared"] > 50              # RA tracks at 15″/s at the end
    for a in aux.values():
        if a["compared"]:
            assert a["max_abs_arcsec"] <= bound


def test_sensor_log_has_the_maintenance_columns(full_run):
    """sensor.log adds per motor the speed and the 1 s gear reduction, per axis the auxiliary
    angle and its difference from the main encoder; at the slew the reduction column is the
    plant's ratio and the motor speed the slew's motor speed (12.58 rad/s, Table 1)."""
    sc, res, out = full_run
    lines = (out / "sensor.log").read_text().splitlines()
    cols = lines[1][2:].split()
    assert cols == list(("t_s",) + SENSOR_COLUMNS[1:] + sensor_columns(R.BOARD_NAMES))
    rows = [dict(zip(cols, ln.split())) for ln in lines[2:]]
    at = [r for r in rows if 2.0 <= float(r["t_s"]) <= 2.4]       # slewing, after settling
    assert at
    for r in at:
        assert abs(float(r["ra_gear_reduction_a"]) - 360.4886) < 0.5
        assert abs(float(r["dec_motor_b_speed_rad_s"]) - 12.583) < 0.2
    assert any(math.isfinite(float(r["ra_aux_minus_main_arcsec"])) for r in rows)


def test_lab_network_runs_with_the_four_tachometers(tmp_path):
    """The lab network (the shipped scenario's network, shortened) builds the paper's lab kinds,
    every one answers the health check, and the report's maintenance section has the four motors
    and no auxiliary encoder."""
    from host.scenario import load_scenario
    shipped = load_scenario(__import__("pathlib").Path(__file__).resolve().parents[1] / "scenarios" / "lab-slew-track.yaml")
    assert shipped.network == "lab"
    sc = _sc("network: lab\nsegments:\n  - {name: s, axis: both, mode: slew, duration_s: 1.5, settle_s: 1}\n", tmp_path)
    rep = run_scenario(sc, tmp_path / "out", plots=False).report
    assert list(rep["nodes"]) == list(R.NETWORKS["lab"]) == list(rep["boards"])
    assert all(b["state"] == "OPERATIONAL" for n, b in rep["boards"].items() if n != "gateway")   # the gateway: no NMT
    assert list(rep["maintenance"]["motors"]) == ["ra_a", "ra_b", "dec_a", "dec_b"]
    assert rep["maintenance"]["aux_minus_main_arcsec"] == {}
    header = (tmp_path / "out" / "sensor.log").read_text().splitlines()[1].split()
    assert "dec_gear_reduction_b" in header and not any("aux" in c for c in header)
