"""The wired network is a CANopen network: an independent canopen master (canopen's RemoteNode
on its own bus, tests/canopen_sim.PumpedNetwork) reads identity and parameters of every board by
SDO and they are what the firmware runs; the host's power-on reads the same into report.json."""

import json

import pytest

from boards.registry import BOARDS
from bus import protocol as P
from boards.registry import network_boards, network_nodes
from bus.eds.objects import serial_number
from host.network import build_network
from host.runner import run_scenario
from host.scenario import parse_scenario
from canopen_sim import PumpedNetwork

#: the boards of the default (basic) network that answer the health check
BASIC_NODES = network_nodes("basic")

#: the boards with a CANopen device (the USB gateway, the host's node, has none)
CANOPEN_BOARDS = {name: (s, i) for name, (s, i) in BOARDS.items() if s.canopen}

SCENARIO = "name: c\nnetwork: full\nsegments:\n  - {name: a, axis: ra, mode: track, direction: 1, duration_s: 0.5}\n"


@pytest.fixture
def tel(tmp_path):
    t = build_network(parse_scenario(SCENARIO, str(tmp_path / "s.yaml")), boards=tuple(BOARDS))   # every board
    yield t
    t.close()


def _expected_parameters(board) -> dict:
    """What the firmware runs, in the EDS units (computed here from the firmware's attributes)."""
    if board.KIND == "axis":
        return {(0x2000, 1): round(board.kp * 1e6), (0x2000, 2): round(board.ki * 1e6),
                (0x2000, 3): round(board.u_max * 32767), (0x2000, 4): round(board.counter_fraction * 32767)}
    if board.KIND == "reader":
        per_deg = 3600 / (1_296_000 / 2 ** 29)
        return {(0x2100, 1): round(board.low_limit_deg * per_deg), (0x2100, 2): round(board.high_limit_deg * per_deg),
                (0x2101, 0): board.offset_counts}
    if board.KIND == "display":
        return {(0x2300, 1): board.refresh_period_us // 1000, (0x2300, 2): board.stale_timeout_us // 1000}
    if board.KIND == "dome":
        return {(0x2400, 1): round(board.max_rate_deg_s * 1000), (0x2400, 2): round(board.acceleration_deg_s2 * 1000),
                (0x2400, 3): round(board.deadband_deg * 100), (0x2400, 4): round(board.park_azimuth_deg * 100),
                (0x2400, 5): round(board.latitude_deg * 1e6)}
    if board.KIND == "weather":
        return {(0x2500, 1): round(board.high_wind_limit_m_s * 100), (0x2500, 2): round(board.high_wind_clear_m_s * 100),
                (0x2500, 3): board.clear_hold_us // 1_000_000, (0x2500, 4): round(board.humidity_limit_pct * 100)}
    if board.KIND == "tachometer":
        return {(0x2300, 0): board.counts_per_rev}
    if board.KIND == "velocity_reader":
        return {(0x2300, 0): board.qei_counts_per_rev}
    if board.KIND == "aux_encoder":
        return {(0x2400, 2): int(board.turns_seeded), (0x2400, 3): 17}
    return {(0x2200, 1): board.travel_halfsteps, (0x2200, 2): round(1e6 / board.step_period_us)}


def test_remote_node_reads_identity_and_parameters_of_every_board(tel):
    master = PumpedNetwork(tel.scheduler, tel.network)
    tel.scheduler.run_until(20_000)
    for name, (spec, inst) in CANOPEN_BOARDS.items():
        node = master.add_remote(spec.firmware.CANOPEN_KIND, int(inst.node_id))
        board = tel.boards[name]
        assert node.sdo[0x1000].raw == int(spec.device_type) << 16
        assert node.sdo[0x1018][2].raw == int(spec.device_type)
        assert node.sdo[0x1018][4].raw == serial_number(int(spec.device_type), int(inst.node_id))
        assert node.sdo[0x1008].raw.startswith("schmidt-fil ")            # segmented upload
        assert node.sdo[0x100A].raw.startswith("schmidt-fil ")
        for (index, sub), value in _expected_parameters(board).items():
            obj = node.sdo[index] if sub == 0 else node.sdo[index][sub]
            assert obj.raw == value, (name, hex(index), sub)
        assert node.sdo[0x2F00][3].raw == 0                                # reset cause POWER_ON
    # a write reaches the firmware (volatile, as SET_KP): Kp of the RA axis
    ra = master.nodes[int(P.NodeId.RA_AXIS)]
    ra.sdo[0x2000][1].raw = 500
    assert tel.boards["ra-axis"].kp == pytest.approx(500e-6)


def test_nmt_from_the_master_gates_the_process_data(tel):
    """Booted boards send no PDO until NMT start; NMT stop silences them again (heartbeat only)."""
    master = PumpedNetwork(tel.scheduler, tel.network)
    tel.scheduler.run_until(100_000)
    pdo_ids = {P.axis_status_cob_id(1), P.position_cob_id(3), P.focus_status_cob_id()}
    assert not {cid for _, cid, _ in master.received} & pdo_ids
    master.nmt.send_command(0x01)                                          # start all
    tel.scheduler.run_until(tel.scheduler.now_us + 300_000)
    assert pdo_ids <= {cid for _, cid, _ in master.received}
    master.nmt.send_command(0x02)                                          # stop all
    t_stop = tel.scheduler.now_us + 1_000
    tel.scheduler.run_until(tel.scheduler.now_us + 1_500_000)
    after = [(t, cid, d) for t, cid, d in master.received if t > t_stop]
    assert not {cid for _, cid, _ in after} & pdo_ids
    assert {cid for _, cid, d in after if d == bytes([4])} >= {P.heartbeat_cob_id(n) for n in BASIC_NODES}


def test_report_lists_identity_and_parameters_read_back_over_sdo(tmp_path):
    sc = parse_scenario(SCENARIO, str(tmp_path / "s.yaml"))
    run_scenario(sc, tmp_path / "out", plots=False)
    on_disk = json.loads((tmp_path / "out" / "report.json").read_text())
    for name in network_boards("basic"):  # the boards a default run builds
        spec, inst = BOARDS[name]
        if not spec.canopen:
            continue                          # the USB gateway: the host's node, no OD
        row = on_disk["boards"][name]
        assert row["identity"]["product_code"] == int(spec.device_type)
        assert row["identity"]["serial_number"] == serial_number(int(spec.device_type), int(inst.node_id))
        assert row["state"] == "OPERATIONAL"
        params = row["parameters"]
        assert params and all(p["value"] is not None or p.get("abort") for p in params.values())
    # read back = what the firmware ran (the report's controller section reads the firmware)
    kp = on_disk["controller"]["ra"]["kp_duty_per_arcsec_s"]
    assert on_disk["boards"]["ra-axis"]["parameters"]["0x2000:1"]["value"] == round(kp * 1e6)
    assert on_disk["boards"]["ra-axis"]["identity"]["device_name"] == "schmidt-fil axis controller"
