"""An external host program drives the emulated telescope over the documented frames: in the same
process on the in-process bus (docs/serve.md), and through ``schmidt-fil serve``'s monitor, which
logs what that host sent and commands nothing itself."""

from __future__ import annotations

import json
import socket
from pathlib import Path

import can
import numpy as np
import pytest

from bus import protocol as P
from boards.registry import network_nodes
from host.cli import main
from host.monitor import PassiveHostError
from host.network import build_network

from host.scenario import load_scenario
from host.serve import DEFAULT_SCENARIO, ServeSession, serve_scenario, served_interface

#: the boards of the default (basic) network that answer the health check
BASIC_NODES = network_nodes("basic")

ROOT = Path(__file__).resolve().parent.parent

SIDEREAL_ARCSEC_S = 15.0


#: QEI resolution at the axis from the documents (4.608e6 counts/rev × 24.5 roller, paper §2.2/§3.2).
ARCSEC_PER_COUNT = 1_296_000.0 / (4_608_000 * 24.5)

def _msg(cob_id: int, data: bytes) -> can.Message:
    return can.Message(arbitration_id=cob_id, data=data, is_extended_id=False)


def _drain(bus: can.BusABC) -> list[can.Message]:
    out = []
    while (m := bus.recv(0.0)) is not None:
        out.append(m)
    return out


def _pings() -> list[can.Message]:
    """The health check of docs/protocol.md: an SDO upload of 0x1000 to every board."""
    return [_msg(P.sdo_request_cob_id(n), P.encode_sdo(0x40, 0x1000, 0)) for n in BASIC_NODES]


def _nmt_start() -> can.Message:
    return _msg(P.nmt_cob_id(), P.encode_nmt(P.NmtCommand.START))


def _track_ra() -> can.Message:
    return _msg(P.axis_command_cob_id(P.NODE_RA_AXIS), P.encode_axis_command(P.AxisCommand.TRACK, 1, 0))


def _ra_rates(frames: list[can.Message], window_s: float = 0.1) -> tuple[float, np.ndarray]:
    """Mean rate and 100 ms window rates [arcsec/s] from AXIS_STATUS_RA frames (QEI counts, 24-bit
    wrap undone; timestamps are simulated seconds on the in-process bus)."""
    st = [(m.timestamp, P.decode(m.arbitration_id, bytes(m.data)).qei_counts) for m in frames
          if m.arbitration_id == P.axis_status_cob_id(P.NODE_RA_AXIS)]
    t = np.array([a for a, _ in st])
    c = np.unwrap(np.array([b for _, b in st], dtype=float), period=1 << 24)
    mean = (c[-1] - c[0]) * ARCSEC_PER_COUNT / (t[-1] - t[0])
    n = int(round(window_s / 0.010))
    windows = (c[n:] - c[:-n]) * ARCSEC_PER_COUNT / (t[n:] - t[:-n])
    return mean, windows


def _host_heartbeat():
    return _msg(P.heartbeat_cob_id(P.NODE_HOST), P.encode_heartbeat(P.NodeState.OPERATIONAL))


@pytest.fixture
def scenario():
    return load_scenario(DEFAULT_SCENARIO)


def test_external_python_host_on_the_in_process_bus(scenario):
    """A second python-can Bus on build_network's channel is a host: its SDO uploads of 0x1000
    get all five answers (the device type), NMT start makes the boards OPERATIONAL (heartbeat
    state 5), its TRACK makes RA track 15″/s (report bounds: mean within 0.2″/s, 100 ms peak
    error < 25 %), and AXIS_COMMANDs with a wrong DLC or device type are counted as malformed by
    the axis board (answered by EMCY frames), which keeps tracking."""
    tel = build_network(scenario)
    ext = can.Bus(interface="schmidt-sim", channel=tel.network.channel)
    sched = tel.scheduler
    try:
        sched.run_until(300_000)                         # boards booted (boot-up at 0 s)
        _drain(ext)
        for m in _pings():
            ext.send(m)
        t_ping_s = sched.now_us / 1e6
        sched.run_until(sched.now_us + 10_000)
        answers = {P.node_of(m.arbitration_id): m for m in _drain(ext)
                   if P.frame_kind(m.arbitration_id) == "SDO_RESPONSE"}
        assert sorted(answers) == sorted(BASIC_NODES)
        for node, m in answers.items():
            sdo = P.decode(m.arbitration_id, bytes(m.data))
            assert (sdo.command, sdo.index, sdo.data >> 16) == (0x43, 0x1000, P.DEVICE_TYPE_OF_NODE[node])
            assert t_ping_s < m.timestamp < t_ping_s + 0.002, (node, m)
        ext.send(_nmt_start())
        # a live host: its CiA heartbeat every second keeps the axes' 2 s host watchdog fed
        sched.call_every(1_000_000, lambda now_us: ext.send(_host_heartbeat()), start_us=sched.now_us)
        sched.run_until(1_100_000)                       # past the 1 s heartbeats
        beats = {P.node_of(m.arbitration_id): P.decode(m.arbitration_id, bytes(m.data)).state
                 for m in _drain(ext) if P.frame_kind(m.arbitration_id) == "HEARTBEAT"}
        assert beats == {n: P.NodeState.OPERATIONAL for n in BASIC_NODES}

        ext.send(_track_ra())
        sched.run_until(sched.now_us + 4_000_000)        # settling (breakaway takes ~3 s)
        _drain(ext)
        sched.run_until(sched.now_us + 2_000_000)
        frames = _drain(ext)
        mean, windows = _ra_rates(frames)
        assert abs(mean - SIDEREAL_ARCSEC_S) < 0.2
        peak_pct = 100 * np.max(np.abs(windows - SIDEREAL_ARCSEC_S)) / SIDEREAL_ARCSEC_S
        assert 0.77 <= peak_pct < 25.0                   # above the QEI resolution floor, within the paper's
        status = [m for m in frames if m.arbitration_id == P.axis_status_cob_id(P.NODE_RA_AXIS)]
        assert len(status) == 200 and P.decode(status[-1].arbitration_id, status[-1].data).mode == P.AxisMode.TRACK

        ra = tel.boards["ra-axis"]
        assert ra.malformed_frames == 0
        cob = P.axis_command_cob_id(P.NODE_RA_AXIS)
        good = P.encode_axis_command(P.AxisCommand.STOP, 1, 0)
        ext.send(_msg(cob, good[:5]))                                         # DLC 5
        ext.send(_msg(cob, bytes([P.DeviceType.AXIS_CONTROLLER]) + good[1:]))  # not the host's type
        sched.run_until(sched.now_us + 100_000)
        assert ra.malformed_frames == 2
        faults = [P.decode(m.arbitration_id, bytes(m.data)) for m in _drain(ext)
                  if m.arbitration_id == P.emcy_cob_id(P.NODE_RA_AXIS)]
        assert [(f.fault_code, f.detail, f.count) for f in faults] == [
            (P.FaultCode.MALFORMED_FRAME, cob, 1), (P.FaultCode.MALFORMED_FRAME, cob, 2)]
        assert ra.mode == P.AxisMode.TRACK                # neither frame was taken as STOP
        assert {n: b.malformed_frames for n, b in tel.boards.items() if n != "ra-axis"} == {
            "dec-axis": 0, "ra-reader": 0, "dec-reader": 0, "focus": 0, "gateway": 0}   # + the host's gateway
    finally:
        ext.shutdown()
        tel.close()


def test_serve_session_logs_what_the_external_host_sent(scenario, tmp_path):
    """With the monitor in the host's place, commands.log holds the external host's NMT START
    and TRACK, errors.log its malformed frame, sensor.log the commanded setpoint, candump.log every
    frame, and report.json counts frames per id and the boards' counters; the monitor itself
    sent nothing."""
    session = ServeSession(scenario, tmp_path)
    ext = can.Bus(interface="schmidt-sim", channel=session.tel.network.channel)
    try:
        session.run(duration_s=0.3)
        ext.send(_nmt_start())
        for m in _pings():
            ext.send(m)
        ext.send(_track_ra())
        session.run(duration_s=0.5)
        ext.send(_msg(P.axis_command_cob_id(P.NODE_RA_AXIS), bytes(3)))   # DLC 3
        session.run(duration_s=0.5)
    finally:
        ext.shutdown()
        rep = session.close()
    assert session.close() is rep                                      # idempotent
    cmds = [l.split() for l in (tmp_path / "commands.log").read_text().splitlines() if not l.startswith("#")]
    assert [c[1:3] for c in cmds] == [["all", "START"], ["ra-axis", "TRACK"]]
    assert float(cmds[0][0]) == pytest.approx(0.3, abs=0.001)
    errors = (tmp_path / "errors.log").read_text()
    assert "0x201 malformed-frame AXIS_COMMAND: field 'dlc'" in errors    # as the monitor decodes it
    assert "ra-axis malformed_frame emcy=0x8200" in errors               # the board's EMCY
    rows = [l.split() for l in (tmp_path / "sensor.log").read_text().splitlines() if not l.startswith("#")]
    assert len(rows) == 130 and rows[0][2] == "0.0000" and rows[-1][1:3] == ["TRACK", "15.0000"]

    assert rep["stopped_by"] == "duration" and rep["simulated_s"] == pytest.approx(1.3)
    assert rep["external_commands"] == {"NMT START": 1, "AXIS_COMMAND TRACK": 1}
    seen = rep["frames_seen"]
    assert seen["NMT"] == 1 and seen["AXIS_COMMAND_RA"] == 2
    assert seen["EMCY_RA_AXIS"] == 1 and all(
        seen[f"HEARTBEAT_{n}"] == 2 and seen[f"SDO_RESPONSE_{n}"] == 1 for n in (
            "RA_AXIS", "DEC_AXIS", "RA_READER", "DEC_READER", "FOCUS"))    # boot-up, 1 s
    assert 98 <= seen["AXIS_STATUS_RA"] <= 100          # only after the NMT start at 0.3 s
    assert rep["boards"]["ra-axis"]["malformed_frames"] == 1 and rep["boards"]["ra-axis"]["limit_refusals"] == 0
    assert rep["monitor"]["malformed_frames"] == 1 and rep["bus_stats"]["interface"] == "sim"
    assert rep["plant"]["ra"]["truth"]["peak_abs_rate_arcsec_s"] > 0
    assert rep["plant"]["dec"]["truth"]["angle_end_deg"] == rep["plant"]["dec"]["truth"]["angle_start_deg"]
    # candump: every frame on the wire; the host's (0x000, 0x201) are exactly the external ones
    dump = (tmp_path / "candump.log").read_text().splitlines()
    assert len(dump) == rep["frames_seen_total"] == rep["monitor"]["candump_frames"]
    assert rep["bus_stats"]["frames"] - len(dump) in (0, 1)             # one may still be on the wire
    assert [l.split()[2] for l in dump if l.split()[2][:3] in ("000", "201")] == [
        "000#0100", "201#1005010000000000", "201#000000"]
    assert json.loads((tmp_path / "report.json").read_text())["external_commands"] == rep["external_commands"]
    assert "AXIS_COMMAND TRACK: 1" in (tmp_path / "report.md").read_text()


def test_monitor_refuses_to_command(scenario, tmp_path):
    """The passive monitor cannot be made to send a PING or a command."""
    with ServeSession(scenario, tmp_path) as session:
        for call in (session.monitor.power_on, lambda: session.monitor.command_axis("ra", "track"),
                     lambda: session.monitor.command_focus_move_to(10)):
            with pytest.raises(PassiveHostError):
                call()


def test_served_interface_lists_every_board_and_its_ids():
    """The start banner's table: five boards; the RA axis sends status/aux/heartbeat/EMCY/SDO
    answers and listens to NMT, the host heartbeat, STOP_ALL, its reader's LIMIT, SDO requests
    and its AXIS_COMMAND."""
    table = {b["board"]: b for b in served_interface()}
    assert list(table) == ["ra-axis", "dec-axis", "ra-reader", "dec-reader", "focus"]
    assert [c for c, _ in table["ra-axis"]["listens"]] == [0x000, 0x710, 0x190, 0x283, 0x601, 0x201]
    assert {c for c, _ in table["ra-axis"]["sends"]} == {0x081, 0x181, 0x281, 0x581, 0x701}
    assert {c for c, _ in table["ra-reader"]["sends"]} == {0x083, 0x183, 0x283, 0x583, 0x703}
    assert [c for c, _ in table["focus"]["listens"]] == [0x000, 0x710, 0x190, 0x605, 0x205]


def test_serve_scenario_moves_the_bus_to_socketcan(scenario):
    """serve keeps the scenario's plant and logs but puts it on SocketCAN (--channel wins)."""
    s = serve_scenario(scenario)
    assert (s.bus.interface, s.bus.channel) == ("socketcan", "vcan0") and s.plant == scenario.plant
    assert serve_scenario(scenario, "can1").bus.channel == "can1"
    assert s.source_path == scenario.source_path


def _has_af_can() -> bool:
    try:
        socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW).close()
        return True
    except (AttributeError, OSError):
        return False


@pytest.mark.skipif(_has_af_can(), reason="this kernel has AF_CAN; the error path needs one without")
def test_cli_serve_without_af_can_says_what_to_do(tmp_path, capsys):
    """Without AF_CAN, serve stops with one line naming the channel and docs/socketcan.md, no
    traceback and no output directory."""
    out = tmp_path / "serve"
    assert main(["serve", "--out", str(out), "--channel", "vcan7", "--duration", "1"]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert "'vcan7'" in err and "docs/socketcan.md" in err and "AF_CAN" in err
    assert not out.exists()


def test_cli_serve_rejects_a_bad_duration(tmp_path, capsys):
    """--duration must be positive: one-line error before anything is built."""
    assert main(["serve", "--out", str(tmp_path / "x"), "--duration", "0"]) == 1
    assert "--duration must be > 0" in capsys.readouterr().err


def test_an_external_host_that_falls_silent_sees_the_axis_stop(scenario):
    """Issue 11: the in-process set-up of docs/serve.md (built-in host client passive); an external
    host starts the nodes, sends SLEW to RA and then nothing. The axis slews until the host
    watchdog (2 s after the SLEW, boards/safety.py) brakes it, reports EMCY HOST_TIMEOUT, and is
    at rest (plant truth) within the watchdog time plus the braking ramp from slew (0.5 s) and
    the supervisor's 200 ms grace."""
    from boards.safety import DEFAULT_SAFETY
    tel = build_network(scenario)
    ext = can.Bus(interface="schmidt-sim", channel=tel.network.channel)
    sched, plant = tel.scheduler, tel.plants["ra"]
    wd_us = DEFAULT_SAFETY.host_watchdog_us
    try:
        sched.run_until(300_000)
        ext.send(_nmt_start())
        sched.run_until(400_000)
        _drain(ext)
        ext.send(_msg(P.axis_command_cob_id(P.NODE_RA_AXIS),
                      P.encode_axis_command(P.AxisCommand.SLEW, 1, 0)))
        t_slew = sched.now_us
        sched.run_until(t_slew + wd_us - 100_000)
        assert abs(plant.axis_rate_arcsec_s) > 5_000            # slewing while the watchdog runs
        stopped_at = None
        while sched.now_us < t_slew + wd_us + 1_500_000:
            sched.run_until(sched.now_us + 10_000)
            if stopped_at is None and abs(plant.axis_rate_arcsec_s) < DEFAULT_SAFETY.brake_stop_tol_arcsec_s:
                stopped_at = sched.now_us
        assert stopped_at is not None
        assert t_slew + wd_us < stopped_at <= t_slew + wd_us + 700_000 + 50_000
        emcy = [P.decode(m.arbitration_id, bytes(m.data)) for m in _drain(ext)
                if m.arbitration_id == P.emcy_cob_id(P.NODE_RA_AXIS)]
        assert [(e.fault_code, e.detail) for e in emcy
                if e.fault_code == P.FaultCode.HOST_TIMEOUT] == [(P.FaultCode.HOST_TIMEOUT, wd_us // 1000)]
        assert tel.boards["ra-axis"].host_timed_out
    finally:
        ext.shutdown()
        tel.close()


def test_docs_serve_in_process_example_runs_verbatim(capsys, monkeypatch):
    """The in-process example of docs/serve.md, executed exactly as written (from the repository
    root): five boot-up messages, five SDO answers to its health check, and after NMT start
    the RA axis tracks."""
    text = (ROOT / "docs/serve.md").read_text(encoding="utf-8")
    section = text.split("## In the same Python process", 1)[1]
    code = section.split("```python\n", 1)[1].split("```", 1)[0]
    monkeypatch.chdir(ROOT)
    scope: dict = {}
    exec(compile(code, "docs/serve.md", "exec"), scope)
    lines = capsys.readouterr().out.splitlines()
    assert sum("HEARTBEAT" in ln and "state=BOOT" in ln for ln in lines) == 5, lines           # at power-on
    assert sum("SDO_RESPONSE" in ln and "command=67" in ln and "index=4096" in ln
               for ln in lines) == 5, lines                                                    # the health check
    tel = scope["tel"]
    assert tel.plants["ra"].axis_rate_arcsec_s == pytest.approx(15.0, abs=5.0)   # tracking, not stopped
