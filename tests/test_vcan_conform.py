"""``schmidt-fil serve`` on a real ``vcan0`` against two external CANopen masters (other processes).

* canopen's own ``RemoteNode`` on a socketcan ``Network`` (the library's Notifier thread, its
  wall-clock SDO timeouts: an external master as a user would write one) reads every node's
  identity and parameters by SDO;
* ``schmidt-fil conform`` (its own process) runs the whole suite with motion allowed, waiting on
  the devices' clock (``--clock device``, docs/conformance.md): every functional check must
  pass; the timing checks are run with ``--timing report`` and recorded beside serve's pacing
  lateness and the device clock's rate (in CI's QEMU guest the CPU is emulated in software and
  the emulator behind ``serve`` runs slower than real time: docs/socketcan.md).

Needs AF_CAN and an up ``vcan0`` (CI: the QEMU guest, ``tests/test_vcan_guest.py``).
"""

from __future__ import annotations

import json
import os
import queue
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from test_vcan import _WHY, CHANNEL, _record
from test_vcan_serve import START_TIMEOUT_S, _lines, _wait_for

ROOT = Path(__file__).resolve().parent.parent
EDS_DIR = ROOT / "bus" / "eds"
#: serve's scenario: the default network with the plant's imperfections off (the file says why).
SCENARIO = ROOT / "tests" / "guest" / "conform-serve.yaml"
pytestmark = [pytest.mark.vcan, pytest.mark.skipif(_WHY is not None, reason=_WHY or "")]

#: Wall-clock limit of the conform run [s] (≈ 180 s of the boards' time; the guest's emulator
#: runs it at 0.3–1× real time alone, ≈ 0.2× beside the rest of the host's suite, which it now runs
#: beside: tests/test_vcan_guest.py). A guard against a hang: the suite waits on the boards' clock.
CONFORM_TIMEOUT_S = 1800
#: The five boards of serve's default network and their EDS (device type byte of 0x1000).
NODES = {1: "axis_controller", 2: "axis_controller", 3: "position_reader", 4: "position_reader",
         5: "focus_controller"}
#: SDO answer timeout of the external master [s] (wall clock; the emulator behind serve may run
#: hundreds of ms late in the guest).
SDO_TIMEOUT_S = 5.0


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    """One ``serve --channel vcan0`` subprocess for the module; yields its output directory and
    stops it with SIGINT afterwards (exit status and report checked by the last test)."""
    out = tmp_path_factory.mktemp("serve")
    cmd = [sys.executable, "-m", "host.cli", "serve", str(SCENARIO), "--channel", CHANNEL,
           "--duration", "1200", "--out", str(out)]
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            stdin=subprocess.DEVNULL)
    q: queue.Queue = queue.Queue()
    threading.Thread(target=_lines, args=(proc.stdout, q), daemon=True).start()
    seen: list[str] = []
    state = {"out": out, "proc": proc, "stdout": seen}
    try:
        _wait_for(q, "serving on", START_TIMEOUT_S, seen)
        yield state
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        if os.environ.get("VCAN_GUEST_OUT") and out.exists():
            shutil.copytree(out, Path(os.environ["VCAN_GUEST_OUT"]) / "conform-serve", dirs_exist_ok=True)


def _expected_parameters(node_id: int) -> dict:
    """``{(index, sub): value}`` the firmware of serve's default scenario answers for the ranged
    manufacturer objects, from an in-process build of the same scenario (None: the EDS default)."""
    from boards.registry import board_of_node
    from host.network import build_network
    from host.scenario import load_scenario

    tel = build_network(load_scenario(SCENARIO))
    try:
        fw = tel.boards[board_of_node(node_id)]
        return {key: fw.od_read(*key) for key in _ranged_objects(node_id)}
    finally:
        tel.close()


def _ranged_objects(node_id: int) -> list:
    import canopen
    od = canopen.import_od(str(EDS_DIR / f"{NODES[node_id]}.eds"), node_id)
    keys = []
    for index in sorted(i for i in od.indices if 0x2000 <= i < 0x2F00):
        obj = od[index]
        entries = [obj] if isinstance(obj, canopen.objectdictionary.ODVariable) else [
            obj[s] for s in sorted(obj.subindices) if s > 0]
        keys += [(index, v.subindex) for v in entries if (v.min is not None or v.max is not None)
                 and "r" in v.access_type]
    return keys


def test_canopen_remote_node_reads_identity_and_parameters_from_every_node(served):
    """canopen ``RemoteNode`` (EDS of each kind) on a socketcan Network reads from each of the
    five nodes: 0x1000 = the EDS device type; 0x1018 vendor/product/revision/serial, 0x1008 name
    (segmented) and 0x100A version = the EDS (serial: the EDS's $NODEID value); every ranged,
    readable manufacturer object (gains, effort limit, presets, soft limits, encoder offsets,
    travel, LVDT reference...) within its EDS range and equal to what the same scenario's
    firmware answers in-process (or its EDS default); aborted only where neither has a value
    (the LVDT reference before an operator stored one)."""
    import canopen

    net = canopen.Network()
    net.connect(interface="socketcan", channel=CHANNEL, receive_own_messages=False)
    got: dict = {}
    t0 = time.monotonic()
    try:
        for nid, kind in NODES.items():
            node = canopen.RemoteNode(nid, str(EDS_DIR / f"{kind}.eds"))
            node.sdo.RESPONSE_TIMEOUT = SDO_TIMEOUT_S
            net.add_node(node)
            od = node.object_dictionary
            assert node.sdo[0x1000].raw == od[0x1000].default, nid
            for sub in (1, 2, 3, 4):
                assert node.sdo[0x1018][sub].raw == od[0x1018][sub].default, (nid, sub)
            assert node.sdo[0x1008].raw == od[0x1008].default
            assert node.sdo[0x100A].raw == od[0x100A].default
            params = {}
            for index, sub in _ranged_objects(nid):
                var = od[index] if isinstance(od[index], canopen.objectdictionary.ODVariable) else od[index][sub]
                sdo = node.sdo[index] if var is od[index] else node.sdo[index][sub]
                try:
                    value = sdo.raw
                except canopen.SdoAbortedError as exc:     # e.g. the LVDT reference before one is stored
                    params[(index, sub)] = (f"abort 0x{exc.code:08X}", var.default)
                    continue
                assert (var.min is None or value >= var.min) and (var.max is None or value <= var.max), \
                    (nid, hex(index), sub, value)
                params[(index, sub)] = (value, var.default)
            assert params, f"node {nid}: no ranged manufacturer objects"
            got[nid] = params
    finally:
        net.disconnect()
    wall_s = time.monotonic() - t0
    aborts = 0
    for nid, params in got.items():
        want = _expected_parameters(nid)
        for key, (value, default) in params.items():
            if isinstance(value, str):
                # an abort only where the firmware has no value and the EDS no default (docs/canopen.md:
                # the host reports such an object with its abort code)
                assert want[key] is None and default is None, (nid, key, value)
                aborts += 1
            else:
                assert value == (want[key] if want[key] is not None else default), (nid, key, value, want[key])
    _record("remote_node_vcan0", {"nodes": len(got), "parameters": sum(len(p) for p in got.values()),
                                  "aborted_no_value": aborts, "wall_s": round(wall_s, 2)})


def test_conform_functional_checks_pass_against_serve_on_vcan0(served, tmp_path):
    """conform from another process with motion allowed, waiting on the devices' clock, timing
    reported: exit 0, every functional check passed (more than 300 on five nodes); the timing checks
    recorded with the device clock's rate and serve's pacing lateness."""
    conf_out = tmp_path / "conform"
    t0 = time.monotonic()
    conf = subprocess.run(
        [sys.executable, "-m", "host.cli", "conform", "--interface", "socketcan", "--channel", CHANNEL,
         "--allow-motion", "--clock", "device", "--timing", "report", "--capture", "3",
         "--out", str(conf_out)], cwd=ROOT, stdin=subprocess.DEVNULL, capture_output=True, text=True,
        timeout=CONFORM_TIMEOUT_S)
    conform_wall_s = time.monotonic() - t0
    if os.environ.get("VCAN_GUEST_OUT") and conf_out.exists():
        shutil.copytree(conf_out, Path(os.environ["VCAN_GUEST_OUT"]) / "conform-conform", dirs_exist_ok=True)
    log = (conf.stdout + conf.stderr)[-4000:]
    doc = json.loads((conf_out / "conformance.json").read_text())
    functional = [c for c in doc["checks"] if c["kind"] == "functional"]
    failed = [c for c in functional if not c["pass"]]
    timing = [c for c in doc["checks"] if c["kind"] == "timing"]
    _record("conform_vcan0", {
        "functional_checks": len(functional), "functional_failed": [f"{c['node']} {c['id']}: {c['observed']}"
                                                                    for c in failed][:20],
        "timing_checks": len(timing), "clock": doc.get("clock"),
        "timing_outside_tolerance": [f"{c['node']} {c['id']}: {c['observed']}" for c in timing if not c["pass"]],
        "reruns_host_lapsed": doc.get("reruns_host_lapsed", []),
        "conform_wall_s": round(conform_wall_s, 1)})
    assert not failed, f"{failed[:5]}\n{log}"
    assert conf.returncode == 0, log
    assert doc["nodes"] == {str(n): k for n, k in NODES.items()}
    assert len(functional) > 300
    assert doc["clock"]["clock"] == "device" and doc["clock"]["device_s"] > 60
    assert timing and not any(c["asserted"] for c in timing)


def test_serve_stops_cleanly_after_both_masters(served):
    """SIGINT ends serve with status 0 and its report has the pacing lateness (recorded)."""
    proc, out = served["proc"], served["out"]
    proc.send_signal(signal.SIGINT)
    proc.wait(timeout=120)
    assert proc.returncode == 0, "".join(served["stdout"])[-3000:]
    report = json.loads((out / "report.json").read_text())
    assert report["stopped_by"] == "SIGINT" and report["realtime"]["steps"] > 0
    _record("conform_serve_realtime", report["realtime"])
