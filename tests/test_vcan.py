"""Specification on a real Linux SocketCAN ``vcan0``: our frames cross the kernel unchanged, and the
whole emulated telescope runs over it in real time.

These tests need ``AF_CAN`` and an up ``vcan0``; they are skipped elsewhere. CI runs them inside a
QEMU guest that has both (``.ci/vcan-guest/run``, driven by ``tests/test_vcan_guest.py``); on a
Linux machine with CAN support run ``sudo ip link add dev vcan0 type vcan && sudo ip link set vcan0
up`` and ``python -m pytest -m vcan``. Figures (round-trip time, pacing lateness) go to
``$VCAN_GUEST_OUT/vcan-figures.json`` when that variable is set.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import struct
import subprocess
import threading
import time
from pathlib import Path

import can
import pytest

from bus import protocol as P
from boards.registry import network_nodes

#: the boards of the default (basic) network that answer the health check
BASIC_NODES = network_nodes("basic")

ROOT = Path(__file__).resolve().parent.parent
CHANNEL = "vcan0"
SCENARIO = ROOT / "scenarios" / "tracking-vcan0.yaml"


def _vcan_unavailable() -> str | None:
    """Why ``vcan0`` cannot be used here, or None if it can."""
    try:
        s = socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)
    except (AttributeError, OSError) as exc:
        return f"no SocketCAN in this kernel (socket(AF_CAN): {exc}); CI runs these in a QEMU guest"
    try:
        s.bind((CHANNEL,))
    except OSError as exc:
        return f"no {CHANNEL} here ({exc}); create it with 'ip link add dev vcan0 type vcan'"
    finally:
        s.close()
    return None


_WHY = _vcan_unavailable()
pytestmark = [pytest.mark.vcan, pytest.mark.skipif(_WHY is not None, reason=_WHY or "")]


def _record(key: str, value) -> None:
    """Add a measured figure to ``$VCAN_GUEST_OUT/vcan-figures.json`` (docs/socketcan.md)."""
    out = os.environ.get("VCAN_GUEST_OUT")
    if not out:
        return
    path = Path(out) / "vcan-figures.json"
    data = json.loads(path.read_text()) if path.exists() else {}
    data[key] = value
    path.write_text(json.dumps(data, indent=1, sort_keys=True))


def _bus(**kw) -> can.BusABC:
    return can.Bus(interface="socketcan", channel=CHANNEL, **kw)


def _sample_frames() -> list[tuple[int, tuple]]:
    """Two frames per protocol COB-ID: every field at its low end, then at its high end."""
    out = []
    for cob, (_, spec, node) in sorted(P.COB_TABLE.items()):
        for end in ("lo", "hi"):
            vals = {}
            for f in spec.fields:
                if f.kind == "enum" and f.enum is not None:
                    members = sorted(int(m) for m in f.enum)
                    vals[f.name] = members[0] if end == "lo" else members[-1]
                else:
                    vals[f.name] = getattr(f, end)
            if "device_type" in spec.tuple_type._fields:
                vals["device_type"] = P.DeviceType.HOST if spec.sender == "host" else P.DEVICE_TYPE_OF_NODE[node]
            out.append((cob, spec.tuple_type(**vals)))
    return out


def _drain(bus: can.BusABC) -> None:
    while bus.recv(0.0) is not None:
        pass


def test_every_protocol_frame_crosses_vcan0_unchanged():
    """Each COB-ID's frame, at both ends of every field, arrives at another socket bit for bit;
    the sender does not hear itself, and the receiver decodes the same values (codecs and DBC)."""
    db = P.load_dbc()
    with _bus() as tx, _bus() as rx:
        _drain(rx)
        frames = _sample_frames()
        for cob, frame in frames:
            data = P.COB_TABLE[cob][1].encode(*frame)
            sent = can.Message(arbitration_id=cob, data=data, is_extended_id=False)
            tx.send(sent)
            got = rx.recv(2.0)
            assert got is not None, f"{P.frame_name(cob)} did not arrive"
            assert got.channel == CHANNEL and got.timestamp > 0
            # direction: the kernel marks frames looped back from this machine as not received
            assert got.equals(sent, timestamp_delta=None, check_channel=False, check_direction=False), (got, sent)
            assert P.decode(got.arbitration_id, bytes(got.data)) == frame
            assert db.decode_message(cob, bytes(got.data), decode_choices=False, scaling=False) \
                == P.dbc_signals(cob, frame)
        assert tx.recv(0.05) is None          # receive_own_messages is off: no echo to the sender
        assert rx.recv(0.05) is None          # and nothing extra arrived
    assert len(frames) == 2 * len(P.COB_TABLE)


def test_round_trip_time_between_two_sockets():
    """An SDO upload request (the health check) and the SDO answer cross vcan0 and back; the time
    is recorded, and only sanity-bounded (a software-emulated guest is slow and has stalls)."""
    ping = can.Message(arbitration_id=P.sdo_request_cob_id(P.NODE_FOCUS), is_extended_id=False,
                       data=P.encode_sdo(0x40, 0x1000, 0))
    beat = can.Message(arbitration_id=P.sdo_response_cob_id(P.NODE_FOCUS), is_extended_id=False,
                       data=P.encode_sdo(0x43, 0x1000, 0, int(P.DeviceType.FOCUS_CONTROLLER) << 16))
    rtt_us = []
    with _bus() as host, _bus() as board:
        for _ in range(300):
            t0 = time.perf_counter()
            host.send(ping)
            got = board.recv(1.0)
            assert got is not None and got.arbitration_id == ping.arbitration_id
            board.send(beat)
            ans = host.recv(1.0)
            assert ans is not None and ans.arbitration_id == beat.arbitration_id
            rtt_us.append((time.perf_counter() - t0) * 1e6)
    rtt_us.sort()
    fig = {"n": len(rtt_us), "p50_us": round(rtt_us[len(rtt_us) // 2]),
           "p99_us": round(rtt_us[int(0.99 * len(rtt_us))]), "max_us": round(rtt_us[-1])}
    _record("round_trip_python_can_us", fig)
    assert 0 < fig["p50_us"] < 50_000


def _send_error_frame(err_class: int) -> bool:
    """Put an error frame (CAN_ERR_FLAG) on vcan0 from a raw socket; False if the kernel refuses."""
    s = socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)
    try:
        s.bind((CHANNEL,))
        s.send(struct.pack("=IB3x8s", socket.CAN_ERR_FLAG | err_class, 8, bytes(8)))
        return True
    except OSError:
        return False
    finally:
        s.close()


@pytest.fixture
def scenario():
    from host.scenario import load_scenario

    return load_scenario(SCENARIO)


def test_boards_and_host_take_no_bus_error_frame_for_a_message(scenario):
    """Error frames a CAN controller reports (here put on vcan0 by hand) are not data frames: no
    board counts them as malformed and the host logs no malformed frame."""
    from host.network import build_network

    tel = build_network(scenario)
    try:
        tel.scheduler.run_until(50_000)
        sent = [_send_error_frame(c) for c in (0x004, 0x020, 0x040, 0x000)]
        if not any(sent):
            pytest.skip("this kernel does not pass error frames sent on vcan0")
        tel.scheduler.run_until(100_000)
        assert {n: b.malformed_frames for n, b in tel.boards.items()} == {n: 0 for n in tel.boards}
        assert tel.client.malformed_frames == 0, tel.client.error_lines()
    finally:
        tel.close()


def test_health_check_waits_in_wall_clock_time_for_a_remote_node():
    """On a real bus the PING's 100 ms answer window is wall-clock time: a node in another process
    (here a thread with its own socket) that answers after 30 ms is found (unpaced, the window
    was over after a few ms of wall clock and the node was reported missing)."""
    from bus.scheduler import Scheduler
    from host.client import HostClient
    from host.realtime import RealtimePacer

    def responder(stop: threading.Event, delay_s: float) -> None:
        with _bus() as b:
            b.set_filters([{"can_id": P.sdo_request_cob_id(P.NODE_FOCUS), "can_mask": 0x7FF,
                            "extended": False}])
            while not stop.is_set():
                m = b.recv(0.01)
                if m is not None:            # answers every SDO request with 0x1000 (device type)
                    time.sleep(delay_s)
                    b.send(can.Message(arbitration_id=P.sdo_response_cob_id(P.NODE_FOCUS), is_extended_id=False,
                                       data=P.encode_sdo(0x43, 0x1000, 0,
                                                         int(P.DeviceType.FOCUS_CONTROLLER) << 16)))

    stop = threading.Event()
    th = threading.Thread(target=responder, args=(stop, 0.030), daemon=True)
    th.start()
    time.sleep(0.2)  # the responder's socket is bound
    sched = Scheduler()
    client = HostClient(bus=_bus(), scheduler=sched, expected_nodes=(P.NODE_FOCUS,))
    pacer = RealtimePacer(start_sim_us=0)
    client.advance = lambda t_us: pacer.run_until(sched, t_us)
    try:
        health = client.power_on()
    finally:
        stop.set()
        th.join(2)
        client.bus.shutdown()
    assert health.ok, client.error_lines()
    # answered 30 ms (plus scheduling) after the PING, inside the 100 ms window: simulated time
    # cannot be ahead of the wall clock
    assert 30_000 <= health.answered["focus"] - client.BOOT_US <= client.POWER_ON_US


@pytest.fixture(scope="module")
def tracking(tmp_path_factory):
    """tracking-vcan0.yaml through run_scenario on vcan0 (real time), with candump listening;
    before it, the same scenario on python-can ``virtual`` (the reference, and a warm-up: under
    software emulation the first pass through the code is the slowest).

    Runs write into a local temporary directory (in the guest a tmpfs; the shared output
    directory is a 9p mount whose writes would slow the paced run) and are copied to
    ``$VCAN_GUEST_OUT`` afterwards for inspection."""
    from host.runner import run_scenario
    from host.scenario import load_scenario, parse_scenario

    ref_out = tmp_path_factory.mktemp("tracking-virtual")
    text = SCENARIO.read_text().replace("interface: socketcan", "interface: virtual")
    ref = run_scenario(parse_scenario(text, str(SCENARIO)), ref_out, plots=False).report

    out = tmp_path_factory.mktemp("tracking-vcan0")
    dump = out / "candump-vcan0.log"
    with dump.open("w") as f:
        # -r: a 1 MiB socket buffer so candump keeps up with bursts; -d: report kernel drops
        cd = subprocess.Popen(["candump", "-L", "-d", "-r", str(1 << 20), CHANNEL], stdout=f,
                              stderr=subprocess.PIPE)
    time.sleep(0.5)  # candump has bound its socket
    try:
        t0 = time.perf_counter()
        res = run_scenario(load_scenario(SCENARIO), out, plots=False)
        wall_s = time.perf_counter() - t0
        time.sleep(0.5)
    finally:
        cd.send_signal(signal.SIGINT)
        _, err = cd.communicate(timeout=10)
    assert cd.returncode in (0, -signal.SIGINT), err
    if os.environ.get("VCAN_GUEST_OUT"):
        for d in (ref_out, out):
            shutil.copytree(d, Path(os.environ["VCAN_GUEST_OUT"]) / d.name, dirs_exist_ok=True)
    return {"out": out, "report": res.report, "wall_s": wall_s, "dump": dump,
            "ref_out": ref_out, "ref": ref}


def test_tracking_scenario_runs_on_vcan0(tracking):
    """All five boards answer the health check over vcan0 and the axis tracks at 15″/s with the
    report's measured numbers; the run was paced to the wall clock and its lateness recorded."""
    rep = tracking["report"]
    status = (tracking["out"] / "status.log").read_text()
    assert "health-check ok" in status
    assert rep["bus"]["interface"] == "socketcan" and rep["bus"]["channel"] == CHANNEL
    assert {n: b["state"] for n, b in rep["boards"].items() if n != "gateway"} == {
        n: "OPERATIONAL" for n in ("ra-axis", "dec-axis", "ra-reader", "dec-reader", "focus")}
    assert rep["boards"]["gateway"]["state"] == "CONFIGURED"     # the host's USB gateway, on vcan0 too
    assert all(b["malformed_frames"] == 0 for b in rep["boards"].values())
    (seg,) = rep["segments"]
    assert seg["mode"] == "track" and seg["setpoint_arcsec_s"] == 15.0
    assert abs(seg["mean_rate_arcsec_s"] - 15.0) < 0.2
    assert 0.77 <= seg["peak_error_pct"] < 25.0
    assert 0.0 < seg["rms_error_pct"] < seg["peak_error_pct"]
    rt = rep["realtime"]
    assert rt is not None and rt["steps"] >= rep["simulated_s"] * 1e6 // 5_000 - 1
    # paced: the run cannot finish before its simulated time has passed on the wall clock
    assert tracking["wall_s"] >= rep["simulated_s"] - 0.01
    _record("tracking_vcan0", {"simulated_s": rep["simulated_s"], "wall_s": round(tracking["wall_s"], 2),
                               "realtime": rt, "segment": {k: seg[k] for k in (
                                   "mean_rate_arcsec_s", "peak_error_pct", "rms_error_pct")}})


def test_vcan0_run_equals_the_same_run_on_pythoncan_virtual(tracking):
    """vcan0 delivers every frame before ``send`` returns, so the network behaves exactly as on
    python-can's in-process ``virtual`` bus (also no bit timing): same numbers, same sensor log."""
    rep, ref = tracking["report"], tracking["ref"]
    assert rep["segments"] == ref["segments"]
    assert rep["errors"] == ref["errors"]
    assert (tracking["out"] / "sensor.log").read_text() == (tracking["ref_out"] / "sensor.log").read_text()


def test_candump_hears_every_frame_and_cantools_decodes_it(tracking):
    """candump (can-utils) on vcan0 records the run's traffic; every frame decodes with
    bus/schmidt.dbc, and the periodic frames come at their documented rates."""
    db = P.load_dbc()
    counts: dict[int, int] = {}
    lines = tracking["dump"].read_text().splitlines()
    drops = [line for line in lines if line.startswith("DROPCOUNT")]
    assert not drops, drops                                       # candump lost nothing
    for line in lines:
        _ts, chan, frame = line.split()
        cob_hex, data_hex = frame.split("#")
        cob = int(cob_hex, 16)
        assert chan == CHANNEL and len(cob_hex) == 3, line
        db.decode_message(cob, bytes.fromhex(data_hex))
        P.decode(cob, bytes.fromhex(data_hex))
        counts[cob] = counts.get(cob, 0) + 1
    # the boards send PDOs from the host's NMT start on (after the health check and the SDO
    # reads of identity and parameters, which on the paced bus take wall-clock time)
    t_start = next(float(line.split()[0]) for line in (tracking["out"] / "commands.log").read_text().splitlines()
                   if not line.startswith("#") and "NMT START" in line)
    sim_s = tracking["report"]["simulated_s"] - t_start
    for node in P.AXIS_NODES:
        assert abs(counts[P.axis_status_cob_id(node)] - sim_s * 100) <= 3
        assert abs(counts[P.axis_aux_cob_id(node)] - sim_s * 100) <= 3
    for node in P.READER_NODES:
        assert abs(counts[P.position_cob_id(node)] - sim_s * 100) <= 3
    for node in BASIC_NODES:
        assert counts[P.heartbeat_cob_id(node)] >= int(sim_s)     # 1 s period, + boot-up
        assert counts[P.sdo_response_cob_id(node)] >= 1           # health check, identity, parameters
    assert counts[P.nmt_cob_id()] == 1                            # NMT start after the health check
    assert counts[P.axis_command_cob_id(P.NODE_RA_AXIS)] == 1     # TRACK
    _record("candump_frames", len(lines))
