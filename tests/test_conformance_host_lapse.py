"""A conformance test is run again when a device says the *host's* heartbeat lapsed during it
(docs/conformance.md, "The host's own heartbeat").

The in-process emulator runs at 0.3× a virtual wall clock (as in the device-clock tests) and the
test aid ``--cf-emulator-host-stall 0x201:3`` deschedules the host for 3 s right after its first
command to the RA axis (node 1): the SET of ``preset_write``. The axis's host watchdog (2 s,
docs/faults.md) then stops it, as a real axis must, and the rate check fails for the host's
fault — what happened in CI's QEMU guest on 374533a.
"""

from __future__ import annotations

import json
from pathlib import Path

from boards_fakes import install_axis_firmware
from host.cli import main

SCENARIO = Path(__file__).resolve().parent / "guest" / "conform-serve.yaml"


def _conform(tmp_path, *args: str):
    out = tmp_path / "conf"
    code = main(["conform", "--timing", "report", "--scenario", str(SCENARIO),
                 "--pytest-arg=--cf-emulator-rate=0.3", "--nodes", "1,3", "-k", "preset_write",
                 *args, "--out", str(out)])
    return code, json.loads((out / "conformance.json").read_text())


def _failed(doc) -> set:
    return {c["id"] for c in doc["checks"] if c["asserted"] and not c["pass"]}


def test_a_host_stall_fails_the_check_without_the_rerun(tmp_path, monkeypatch):
    """Control: with no re-run the stalled host fails ``preset_write.effect`` (the axis stopped)."""
    import host.conformance.plugin as P

    monkeypatch.setattr(P, "HOST_LAPSE_RERUNS", 0)
    code, doc = _conform(tmp_path, "--pytest-arg=--cf-emulator-host-stall=0x201:3")
    assert code == 1 and _failed(doc) == {"preset_write.effect"}, _failed(doc)
    assert doc["reruns_host_lapsed"] == []


def test_the_test_is_run_again_when_the_device_reports_the_host_lapsed(tmp_path):
    """With the re-run: exit 0, every counted check passed; the report names the test, the EMCY
    HOST_TIMEOUT of node 1 that proved the lapse, the failed check, and a host gap ≥ 3 s."""
    code, doc = _conform(tmp_path, "--pytest-arg=--cf-emulator-host-stall=0x201:3")
    assert code == 0 and not _failed(doc), _failed(doc)
    assert {c["id"] for c in doc["checks"]} >= {"preset_write.effect", "preset_write.above_high_limit"}
    (rerun,) = doc["reruns_host_lapsed"]
    assert rerun["test"].endswith("test_axis_preset_write[node1]") and rerun["attempt"] == 1
    assert any(line.startswith("node 1 EMCY HOST_TIMEOUT") for line in rerun["lapses"]), rerun
    assert any(f.startswith("preset_write.effect (node 1)") for f in rerun["failed"]), rerun
    assert rerun["host_longest_beat_gap_wall_s"] >= 3.0
    md = (tmp_path / "conf" / "conformance.md").read_text()
    assert "Run again: the host's own heartbeat lapsed" in md


def test_a_failure_without_a_host_lapse_is_not_run_again(tmp_path, monkeypatch):
    """A board that is wrong (SET at 1.3 × the written preset) fails once and is not re-run: the
    re-run needs the device's own statement that the host lapsed, not a failure."""
    from boards.axis_controller import AxisController

    class WrongRateAxis(AxisController):
        def _set_mode(self, mode, rate):
            AxisController._set_mode(self, mode, 1.3 * rate)

    install_axis_firmware(monkeypatch, WrongRateAxis)
    code, doc = _conform(tmp_path)
    assert code == 1 and "preset_write.effect" in _failed(doc), _failed(doc)
    assert doc["reruns_host_lapsed"] == []
