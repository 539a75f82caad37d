"""The gateway as a real HID device: inside the QEMU guest of .ci/vcan-guest (modules uhid, hid,
hid-generic; this machine has no /dev/uhid), ``python -m host.uhid_gateway`` creates it through
/dev/uhid and ``tests/guest/hid_client.py`` — written from docs/usb-gateway.md alone, importing
only the PyPI ``hid`` package (hidapi, hidraw backend) and the standard library — drives it:
every check of the client must pass.

Skipped, with the reason, where the guest cannot boot or the ``hid`` package / libhidapi-hidraw
is missing; under CI (``CI`` set) that is a failure instead (.ci/run sets the guest up and the
test extra installs ``hid``).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

import test_vcan_guest as vcan_guest  # module import: its test is not collected twice

ROOT = Path(__file__).resolve().parent.parent
GUEST = ROOT / ".ci" / "vcan-guest" / "run"
#: Wall-clock limit of the guest run [s]; it normally takes about a minute (docs/usb-gateway.md).
GUEST_TIMEOUT_S = 600


def _not_ready() -> str | None:
    if not sys.platform.startswith("linux"):
        return "the guest needs Linux"
    try:
        import hid  # noqa: F401  (loads libhidapi-hidraw.so.0 or fails)
    except (ImportError, OSError) as exc:
        return f"the PyPI 'hid' package with libhidapi-hidraw0 is needed: {exc}"
    return vcan_guest._guest_not_ready()   # the same QEMU guest (.ci/vcan-guest/run check)


def test_unmodified_hidapi_client_drives_the_gateway_through_uhid(tmp_path):
    """Boot the guest, serve the gateway via /dev/uhid, run the standalone hidapi client: all pass."""
    why = _not_ready()
    if why is not None:
        if os.environ.get("CI"):
            pytest.fail(f"CI must run the uhid guest test (.ci/run sets it up): {why}")
        pytest.skip(f"uhid guest not available: {why}")
    out = tmp_path / "guest"
    cmd = ["bash", str(GUEST), "--out", str(out), "--timeout", str(GUEST_TIMEOUT_S), "--env", "SCHMIDT_FIL_JIT",
           "--", "sh", "tests/guest/uhid_check.sh", sys.executable]
    env = {**os.environ, "SCHMIDT_FIL_JIT": "0"}   # numba's first compile takes ~90 s under TCG
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=ROOT, env=env, stdin=subprocess.DEVNULL, capture_output=True, text=True,
                          timeout=GUEST_TIMEOUT_S + 60)
    wall_s = time.perf_counter() - t0
    log = (proc.stdout + proc.stderr)[-6000:]
    client = out / "uhid-client.json"
    assert client.exists(), f"the client wrote no results (exit {proc.returncode}):\n{log}"
    res = json.loads(client.read_text())
    failed = [c for c in res["checks"] if not c["ok"]]
    assert not failed and len(res["checks"]) >= 10, f"{failed}\n{log}"
    assert proc.returncode == 0, log
    summary = json.loads((out / "uhid-summary.json").read_text())
    assert summary["uhid_events"].get("OPEN", 0) >= 2 and summary["gateway"]["out_malformed"] == 2
    times = json.loads((out / "uhid-times.json").read_text())
    print(f"uhid guest: {len(res['checks'])} client checks passed; wall {wall_s:.1f} s; {times}; "
          f"figures {res['figures']}; bridge summary {summary}")
