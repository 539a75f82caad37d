"""``schmidt-fil conform`` (host/conformance, docs/conformance.md): the in-process emulator passes
every check; the suite fails a board that breaks the documents; the suite is independent of the
project's own codecs and host; the documents it reads agree with each other."""

from __future__ import annotations

import ast
import json
from pathlib import Path

import pytest

from host.cli import main
from host.conformance.documents import load_documents, parse_fault_table

ROOT = Path(__file__).resolve().parent.parent
SUITE = ROOT / "host" / "conformance"

#: Check-id prefixes the full run must contain (one family per item of issue 10's list).
FAMILIES = ("presence.", "identity.", "frames.dlc", "frames.device_type", "timing.heartbeat_period",
            "timing.pdo_period.", "timing.sdo_expedited", "timing.sdo_segmented", "nmt.stop.no_pdo",
            "nmt.reset_node.", "nmt.reset_communication.", "nmt.pre_operational.", "malformed.count",
            "malformed.keeps_running", "emcy.heartbeat_lost", "emcy.error_reset", "axis.SLEW+1.rate",
            "axis.VELOCITY.rate", "axis.OPEN_LOOP.effort", "axis.SET_KP.refused", "axis.VELOCITY.outside_range",
            "axis.direction0_preset", "limit.stop_mode", "limit.toward_refused", "limit.error_reset",
            "focus.refused", "command_log.received", "command_log.refused", "preset_write.effect")


def test_conform_in_process_passes_every_check(tmp_path, capsys):
    """The whole suite against the in-process emulator (default scenario, motion allowed, timing
    asserted): exit 0, every check recorded as passed and asserted, every family of checks present
    for the nodes it applies to, and both reports written."""
    out = tmp_path / "conf"
    assert main(["conform", "--out", str(out)]) == 0, capsys.readouterr().out[-3000:]
    doc = json.loads((out / "conformance.json").read_text())
    checks = doc["checks"]
    failed = [c for c in checks if not c["pass"] or not c["asserted"]]
    assert not failed, failed[:5]
    assert doc["nodes"] == {"1": "axis_controller", "2": "axis_controller", "3": "position_reader",
                            "4": "position_reader", "5": "focus_controller"}
    ids = {c["id"] for c in checks}
    for fam in FAMILIES:
        assert any(i.startswith(fam) for i in ids), fam
    per_node = {n: {c["id"] for c in checks if c["node"] == n} for n in range(1, 6)}
    assert all("nmt.stop.no_pdo" in per_node[n] and "emcy.error_reset" in per_node[n] for n in range(1, 6))
    assert {n for n in range(1, 6) if "limit.toward_refused" in per_node[n]} == {1, 2}
    assert {n for n in range(1, 6) if any(i.startswith("focus.") for i in per_node[n])} == {5}
    md = (out / "conformance.md").read_text()
    assert f"**{len(checks)} passed, 0 failed**" in md


def test_conform_fails_an_absent_node(tmp_path):
    """A node that is not on the bus (--nodes 1,9): exit 1, the presence check of node 9 failed."""
    out = tmp_path / "conf"
    assert main(["conform", "--nodes", "1,9", "-k", "presence", "--out", str(out)]) == 1
    doc = json.loads((out / "conformance.json").read_text())
    bad = [c for c in doc["checks"] if not c["pass"]]
    assert [c["node"] for c in bad] == [9] and bad[0]["id"] == "presence.sdo_0x1000"


def test_conform_catches_a_stopped_node_that_still_sends_pdos(tmp_path, monkeypatch):
    """A firmware defect — PDOs leave the node in every NMT state — fails the NMT stop check."""
    from boards_fakes import install_leaky_pdo_gate

    install_leaky_pdo_gate(monkeypatch)
    out = tmp_path / "conf"
    assert main(["conform", "--nodes", "3", "-k", "nmt_stop", "--out", str(out)]) == 1
    doc = json.loads((out / "conformance.json").read_text())
    assert {c["id"] for c in doc["checks"] if not c["pass"]} == {"nmt.stop.no_pdo"}


def test_conform_usage_errors_are_one_line(capsys):
    """--interface without --channel and a missing scenario file: exit 1, one line naming it."""
    assert main(["conform", "--interface", "socketcan"]) == 1
    assert main(["conform", "--scenario", "no/such.yaml"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and "--channel" in err[0] and "no/such.yaml" in err[1]


#: Modules of the suite that must not use the project's codecs, host or firmware (the emulator
#: adapter is the one exception: it builds the device under test).
INDEPENDENT = [p for p in SUITE.glob("*.py") if p.name != "emulator.py"]
FORBIDDEN = ("bus", "boards", "plant", "host.client", "host.canopen_master", "host.network", "host.monitor")


@pytest.mark.parametrize("path", INDEPENDENT, ids=[p.name for p in INDEPENDENT])
def test_suite_is_written_from_the_documents_only(path):
    """No check module imports the project's codecs (bus.*), firmware, plant or host client."""
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        names = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            names = [node.module]
        for n in names:
            assert not any(n == f or n.startswith(f + ".") for f in FORBIDDEN), f"{path.name} imports {n}"


def test_documents_agree_with_the_firmware_tables():
    """The fault table the suite parses from docs/protocol.md equals the EMCY table of
    bus/eds/objects.py; the DBC's cyclic messages have the EDS event timers of their TPDOs."""
    from bus.eds.objects import EMCY_CODES, KINDS

    docs = load_documents()
    table = {e.name: (e.fault_code, e.code, "condition" if e.condition else "event") for e in EMCY_CODES.values()}
    assert docs.emcy_codes == table
    for kind in KINDS.values():
        for pdo in kind.tpdos:
            for node in kind.nodes:
                msg = docs.message(pdo.cob_id_for(node))
                assert msg is not None
                assert (msg.cycle_time or 0) in (0, pdo.period_ms), (msg.name, msg.cycle_time, pdo.period_ms)
                if msg.cycle_time:
                    assert msg.cycle_time == pdo.period_ms


def test_fault_table_parse_error_names_the_file():
    with pytest.raises(ValueError, match="x.md: no fault-code table"):
        parse_fault_table("no table here", "x.md")


def test_host_setpoints_follow_a_preset_written_to_the_firmware():
    """0x2001 is writable: the host's reported setpoint of a preset is the firmware's current
    preset (one source), not the build's table."""
    from host.network import build_network
    from host.scenario import load_scenario

    tel = build_network(load_scenario(ROOT / "scenarios" / "tracking-low-preload.yaml"))
    try:
        assert tel.client.preset_rates_arcsec_s[("set", "ra")] == 600.0
        tel.boards["ra-axis"].od_write(0x2001, 2, 900_000)
        assert tel.client.preset_rates_arcsec_s[("set", "ra")] == 900.0
        assert tel.client.preset_rates_arcsec_s[("set", "dec")] == 600.0
        assert tel.boards["ra-axis"].od_read(0x2001, 2) == 900_000
    finally:
        tel.close()
