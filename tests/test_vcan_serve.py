"""Specification of ``schmidt-fil serve`` on a real ``vcan0``: another process is the host.

``schmidt-fil serve --channel vcan0`` runs as a subprocess; this test process is the external
host program, with its own python-can ``socketcan`` socket: it PINGs, commands RA tracking and
reads the status frames, then stops the server with SIGINT and reads its logs and report. Needs
AF_CAN and an up ``vcan0`` (CI: the QEMU guest, ``tests/test_vcan_guest.py``).
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

import can
import pytest

from bus import protocol as P
from boards.registry import network_nodes
from test_vcan import _WHY, CHANNEL, _record

#: the boards of the default (basic) network that answer the health check
BASIC_NODES = network_nodes("basic")

ROOT = Path(__file__).resolve().parent.parent
pytestmark = [pytest.mark.vcan, pytest.mark.skipif(_WHY is not None, reason=_WHY or "")]

SETTLE_FRAMES = 350          #: AXIS_STATUS_RA frames (10 ms of simulated time each) skipped after TRACK
MEASURE_FRAMES = 100         #: frames measured after that (1 s of simulated time)
#: Wall-clock limit for the server to start (Python start and imports take ~10 s in the guest) [s].
START_TIMEOUT_S = 120
ARCSEC_PER_COUNT = 1_296_000.0 / (4_608_000 * 24.5)


def _lines(stream, q: queue.Queue) -> None:
    for line in stream:
        q.put(line)
    q.put(None)


def _wait_for(q: queue.Queue, prefix: str, timeout_s: float, seen: list) -> None:
    deadline = time.monotonic() + timeout_s
    while True:
        line = q.get(timeout=max(0.01, deadline - time.monotonic()))
        if line is None:
            raise AssertionError("serve exited before it served:\n" + "".join(seen))
        seen.append(line)
        if line.startswith(prefix):
            return


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    """A serve subprocess on vcan0 driven from this process; the frames this host received, the
    server's stdout and its output directory (a local temporary directory, copied to
    ``$VCAN_GUEST_OUT`` afterwards)."""
    out = tmp_path_factory.mktemp("serve-vcan0")
    cmd = [sys.executable, "-m", "host.cli", "serve", "--channel", CHANNEL, "--duration", "30", "--out", str(out)]
    got: list[tuple[float, can.Message]] = []
    stdout: list[str] = []
    # the kernel filters for this host: heartbeats and the RA axis's periodic frames (fewer
    # wake-ups for a slow guest; the server's candump.log has everything)
    filters = [{"can_id": P.heartbeat_cob_id(P.NODE_RA_AXIS) & 0x7F0, "can_mask": 0x7F0, "extended": False},
               {"can_id": P.sdo_response_cob_id(P.NODE_RA_AXIS) & 0x7F0, "can_mask": 0x7F0, "extended": False}] + [
        {"can_id": cob, "can_mask": 0x7FF, "extended": False}
        for cob in (P.axis_status_cob_id(P.NODE_RA_AXIS), P.axis_aux_cob_id(P.NODE_RA_AXIS))]
    with can.Bus(interface="socketcan", channel=CHANNEL, receive_own_messages=False,
                 ignore_rx_error_frames=True, can_filters=filters) as host:
        proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                stdin=subprocess.DEVNULL)
        q: queue.Queue = queue.Queue()
        threading.Thread(target=_lines, args=(proc.stdout, q), daemon=True).start()
        try:
            t_start = time.monotonic()
            _wait_for(q, "serving on", START_TIMEOUT_S, stdout)
            start_s = time.monotonic() - t_start

            hb = can.Message(arbitration_id=P.heartbeat_cob_id(P.NODE_HOST), is_extended_id=False,
                             data=P.encode_heartbeat(P.NodeState.OPERATIONAL))
            last_hb = [0.0]

            def collect(until) -> None:
                while not until():
                    if time.monotonic() - last_hb[0] >= 0.5:     # a live host: heartbeat (2 s host watchdog)
                        host.send(hb)
                        last_hb[0] = time.monotonic()
                    m = host.recv(0.05)
                    if m is not None:
                        got.append((time.monotonic(), m))

            t0 = time.monotonic()
            collect(lambda: time.monotonic() - t0 > 0.3)          # the boards' boot heartbeats
            # the health check (SDO upload of 0x1000 from every board), then NMT start
            for node in BASIC_NODES:
                host.send(can.Message(arbitration_id=P.sdo_request_cob_id(node), is_extended_id=False,
                                      data=P.encode_sdo(0x40, 0x1000, 0)))
            host.send(can.Message(arbitration_id=P.nmt_cob_id(), is_extended_id=False,
                                  data=P.encode_nmt(P.NmtCommand.START)))
            i_ping = len(got)
            t_ping = time.monotonic()
            collect(lambda: time.monotonic() - t_ping > 0.5)
            host.send(can.Message(arbitration_id=P.axis_command_cob_id(P.NODE_RA_AXIS), is_extended_id=False,
                                  data=P.encode_axis_command(P.AxisCommand.TRACK, 1, 0)))
            i_track = len(got)
            ra_status = P.axis_status_cob_id(P.NODE_RA_AXIS)
            n_status = lambda: sum(1 for _, m in got[i_track:] if m.arbitration_id == ra_status)  # noqa: E731
            collect(lambda: n_status() >= SETTLE_FRAMES + MEASURE_FRAMES + 1 or time.monotonic() - t_ping > 25)
            proc.send_signal(signal.SIGINT)
            t_sig = time.monotonic()
            proc.wait(timeout=60)
            stop_s = time.monotonic() - t_sig
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
    while (line := q.get(timeout=10)) is not None:     # the reader thread stops at end of file
        stdout.append(line)
    if os.environ.get("VCAN_GUEST_OUT"):
        shutil.copytree(out, Path(os.environ["VCAN_GUEST_OUT"]) / out.name, dirs_exist_ok=True)
    return {"out": out, "frames": got, "i_ping": i_ping, "i_track": i_track, "stdout": "".join(stdout),
            "returncode": proc.returncode, "start_s": start_s, "stop_s": stop_s}


def test_serve_answers_an_external_ping_with_five_heartbeats(served):
    """The external host's health check on vcan0 (SDO upload of 0x1000) is answered by each of
    the five boards with its device type, and the start banner named the channel and every node."""
    answers = {}
    for t, m in served["frames"][served["i_ping"]:served["i_track"]]:
        if P.frame_kind(m.arbitration_id) == "SDO_RESPONSE":
            answers.setdefault(P.node_of(m.arbitration_id), P.decode(m.arbitration_id, bytes(m.data)))
    assert sorted(answers) == sorted(BASIC_NODES), served["stdout"]
    assert all((a.command, a.index, a.data >> 16) == (0x43, 0x1000, P.DEVICE_TYPE_OF_NODE[n])
               for n, a in answers.items())
    banner = served["stdout"]
    assert f"channel {CHANNEL}" in banner and "node 1 ra-axis" in banner and "node 5 focus" in banner
    assert "listens 000 710 190 283 601 201" in banner


def test_serve_tracks_at_15_arcsec_s_for_an_external_track_command(served):
    """After the external TRACK, AXIS_STATUS_RA reports TRACK at 100 frames per simulated second;
    after 3.5 s settling its QEI counts give 15″/s within 0.3″/s (frames are 10 ms apart in
    simulated time), and in wall-clock time they arrive at roughly 100/s (paced, not asserted
    tightly: the guest's CPU is emulated)."""
    ra_status = P.axis_status_cob_id(P.NODE_RA_AXIS)
    after = served["frames"][served["i_track"]:]
    status = [(t, P.decode(m.arbitration_id, bytes(m.data))) for t, m in after if m.arbitration_id == ra_status]
    assert len(status) > SETTLE_FRAMES + MEASURE_FRAMES, len(status)
    window = status[SETTLE_FRAMES:SETTLE_FRAMES + MEASURE_FRAMES + 1]
    assert {f.mode for _, f in window} == {P.AxisMode.TRACK}
    d_counts = (window[-1][1].qei_counts - window[0][1].qei_counts) % (1 << 24)
    rate = d_counts * ARCSEC_PER_COUNT / (MEASURE_FRAMES * 0.010)
    assert abs(rate - 15.0) < 0.3, rate
    # the other periodic frames of the axis came at the same rate (simulated time)
    aux = sum(1 for _, m in after if m.arbitration_id == P.axis_aux_cob_id(P.NODE_RA_AXIS))
    assert abs(aux - len(status)) <= 2
    wall_s = status[-1][0] - status[0][0]
    per_s = (len(status) - 1) / wall_s
    # paced, never faster than real time (a functional property of serve). How much slower it
    # runs depends on the CPU: in CI's QEMU guest the CPU is emulated (TCG), so the lower side is
    # recorded, not asserted (issue 10: in the guest timing is reported, functional checks
    # asserted); one CI run of this session measured 49.4 frames per wall second there.
    assert per_s < 115, per_s
    _record("serve_vcan0", {"ra_rate_arcsec_s": round(rate, 4), "status_frames_per_wall_s": round(per_s, 1),
                            "start_s": round(served["start_s"], 2), "stop_s": round(served["stop_s"], 2)})


def test_serve_stops_on_sigint_and_its_logs_hold_the_external_host(served):
    """SIGINT ends serve with status 0; commands.log holds the external NMT START and TRACK, the
    report counts them and the frames per id, candump.log has them, and no board counted a
    malformed frame."""
    out = served["out"]
    assert served["returncode"] == 0, served["stdout"]
    assert "stopped by SIGINT" in served["stdout"]
    cmds = [line.split()[1:3] for line in (out / "commands.log").read_text().splitlines() if not line.startswith("#")]
    assert cmds == [["all", "START"], ["ra-axis", "TRACK"]]
    rep = json.loads((out / "report.json").read_text())
    assert rep["stopped_by"] == "SIGINT" and rep["bus"] == {"interface": "socketcan", "channel": CHANNEL,
                                                            "bitrate": 1_000_000}
    assert rep["external_commands"] == {"NMT START": 1, "AXIS_COMMAND TRACK": 1}
    seen = rep["frames_seen"]
    assert seen["NMT"] == 1 and seen["AXIS_COMMAND_RA"] == 1
    assert seen["AXIS_STATUS_RA"] >= SETTLE_FRAMES + MEASURE_FRAMES
    assert all(b["malformed_frames"] == 0 for b in rep["boards"].values()) and rep["monitor"]["malformed_frames"] == 0
    assert rep["realtime"]["steps"] >= rep["simulated_s"] * 1e6 // 5_000 - 1
    dump = (out / "candump.log").read_text().splitlines()
    assert len(dump) == rep["frames_seen_total"]
    assert [line.split()[2][:4] for line in dump if line.split()[2][:3] in ("000", "201")] == ["000#", "201#"]
    assert all(line.split()[1] == CHANNEL for line in dump)
    rows = [line.split() for line in (out / "sensor.log").read_text().splitlines() if not line.startswith("#")]
    assert rows[-1][1:3] == ["TRACK", "15.0000"]
    assert rep["plant"]["ra"]["truth"]["peak_abs_rate_arcsec_s"] > 10.0
