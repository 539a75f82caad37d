"""``schmidt-fil conform`` against ``schmidt-fil serve`` on a real ``vcan0`` (two processes).

The functional checks must all pass; the timing checks are run with ``--timing report`` and
recorded with the server's pacing lateness (the QEMU guest of CI emulates its CPU in software
and the emulator behind ``serve`` runs late by up to hundreds of ms: docs/socketcan.md).
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
pytestmark = [pytest.mark.vcan, pytest.mark.skipif(_WHY is not None, reason=_WHY or "")]

#: Wall-clock limit of the conform run in the guest [s] (≈ 240 s in real time on the host, measured
#: with the emulator on python-can virtual paced by a thread; the guest's CPU is slower).
CONFORM_TIMEOUT_S = 600


def test_conform_functional_checks_pass_against_serve_on_vcan0(tmp_path):
    """serve on vcan0 (all five boards), conform from another process with motion allowed and
    timing reported: exit 0, every functional check passed, the timing checks recorded; the
    server stopped cleanly and its pacing lateness is recorded beside them."""
    serve_out, conf_out = tmp_path / "serve", tmp_path / "conform"
    cmd = [sys.executable, "-m", "host.cli", "serve", "--channel", CHANNEL, "--duration", "900",
           "--out", str(serve_out)]
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            stdin=subprocess.DEVNULL)
    q: queue.Queue = queue.Queue()
    threading.Thread(target=_lines, args=(proc.stdout, q), daemon=True).start()
    seen: list[str] = []
    try:
        _wait_for(q, "serving on", START_TIMEOUT_S, seen)
        t0 = time.monotonic()
        conf = subprocess.run(
            [sys.executable, "-m", "host.cli", "conform", "--interface", "socketcan", "--channel", CHANNEL,
             "--allow-motion", "--timing", "report", "--reaction-slack", "0.5", "--capture", "3",
             "--out", str(conf_out)], cwd=ROOT, stdin=subprocess.DEVNULL, capture_output=True, text=True,
            timeout=CONFORM_TIMEOUT_S)
        conform_wall_s = time.monotonic() - t0
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    if os.environ.get("VCAN_GUEST_OUT"):
        for d in (serve_out, conf_out):
            if d.exists():
                shutil.copytree(d, Path(os.environ["VCAN_GUEST_OUT"]) / f"conform-{d.name}", dirs_exist_ok=True)
    log = (conf.stdout + conf.stderr)[-4000:]
    doc = json.loads((conf_out / "conformance.json").read_text())
    functional = [c for c in doc["checks"] if c["kind"] == "functional"]
    failed = [c for c in functional if not c["pass"]]
    assert not failed, f"{failed[:5]}\n{log}"
    assert conf.returncode == 0, log
    assert doc["nodes"] == {"1": "axis_controller", "2": "axis_controller", "3": "position_reader",
                            "4": "position_reader", "5": "focus_controller"}
    assert len(functional) > 250
    timing = [c for c in doc["checks"] if c["kind"] == "timing"]
    assert timing and not any(c["asserted"] for c in timing)
    assert proc.returncode == 0
    report = json.loads((serve_out / "report.json").read_text())
    _record("conform_vcan0", {
        "functional_checks": len(functional), "timing_checks": len(timing),
        "timing_outside_tolerance": [f"{c['node']} {c['id']}: {c['observed']}" for c in timing if not c["pass"]],
        "conform_wall_s": round(conform_wall_s, 1), "serve_realtime": report.get("realtime")})
