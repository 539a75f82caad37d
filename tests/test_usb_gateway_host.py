"""The project's host client talks through the USB-HID gateway by default: build_network gives
HostClient a python-can bus made of HID reports (host/gateway_bus.py) over the in-process
hid.device, on the registry's gateway board (node 0x10); serve's passive monitor stays a direct
listener on the CAN bus."""

import can
import pytest

from boards.usb_gateway import UsbGateway
from bus import protocol as p
from host.gateway_bus import HidGatewayBus
from host.monitor import BusMonitor
from host.network import build_network
from host.scenario import parse_scenario
from host.serve import DEFAULT_SCENARIO

#: frames of the host's node (node 0x10): NMT, SDO requests, its heartbeat, TRACK to RA, STOP_ALL
_HOST_IDS = {0x000, 0x190, 0x201, 0x710} | set(range(0x601, 0x680))


@pytest.fixture
def tel():
    sc = parse_scenario(DEFAULT_SCENARIO.read_text(), str(DEFAULT_SCENARIO))
    t = build_network(sc)
    yield t
    t.close()


def test_health_check_and_tracking_through_the_gateway(tel):
    """The default client's bus is the gateway's HID bus; the five boards answer the power-on SDO
    health check; TRACK reaches the RA axis and its status frames come back through IN reports;
    every frame the host put on the wire went through the gateway."""
    gw = tel.boards["gateway"]
    assert isinstance(gw, UsbGateway) and gw.node_id == p.NodeId.HOST
    assert isinstance(tel.client.bus, HidGatewayBus) and tel.host_can_bus is gw.can.bus
    on_wire = []
    tel.network.add_tap(lambda m: on_wire.append(m.arbitration_id) if m.arbitration_id in _HOST_IDS else None)
    health = tel.client.power_on()
    assert health.ok, health.missing
    assert set(health.answered) == {"ra-axis", "dec-axis", "ra-reader", "dec-reader", "focus"}
    tel.client.command_axis("ra", "track")
    tel.scheduler.run_until(tel.scheduler.now_us + 500_000)
    assert tel.client.axes["ra"].mode_name == "TRACK"
    bus = tel.client.bus
    assert tel.client.malformed_frames == 0 and bus.malformed_reports == 0 and bus.lost_reports == 0
    assert gw.tx_frames == len(on_wire) and gw.tx_errors == 0
    assert on_wire.count(0x201) == 1 and on_wire.count(0x000) == 1       # TRACK, NMT start
    assert gw.rx_dropped == 0 and gw.out_malformed == 0


def test_frames_reach_the_client_within_one_usb_frame(tel):
    """CAN → PC: the client decodes each status frame at the next 1 ms USB frame boundary after
    its end on the wire (the queue stays short on this network), never earlier."""
    ends = {}
    tel.network.add_tap(lambda m: ends.setdefault(m.arbitration_id, []).append(tel.scheduler.now_us))
    tel.client.power_on()
    tel.scheduler.run_until(tel.scheduler.now_us + 200_000)
    cob = p.axis_status_cob_id(p.NodeId.RA_AXIS)
    t_client = tel.client.axes["ra"].t_us
    t_wire = max(t for t in ends[cob] if t <= t_client)
    assert t_client % 1_000 == 0 and 0 < t_client - t_wire <= 1_000


def test_report_row_carries_the_gateway_counters(tel):
    """The gateway's board row: its status counters, the CAN → PC latency of what the client took,
    and the PC side of the USB link; read from what ran and consistent with the client."""
    tel.client.power_on()
    tel.client.command_axis("ra", "track")
    tel.scheduler.run_until(tel.scheduler.now_us + 1_000_000)
    row = tel.board_summary()["gateway"]
    gw = tel.boards["gateway"]
    assert row["node"] == 0x10 and row["state"] == "CONFIGURED" and "emcy_sent" not in row
    assert row["rx_dropped"] == 0 and row["out_malformed"] == 0 and row["malformed_frames"] == 0
    assert 1 <= row["queue_high_water"] <= row["queue_depth"] == 32
    # every frame queued for the PC reached the client, but those still queued or in the armed report
    assert 0 <= row["rx_frames"] - tel.client.frames_received <= gw.queue_level + 4
    lat = row["can_to_pc_latency_us"]
    # a frame waits for the next 1 ms USB frame, plus 1 ms per 4 frames queued ahead of it (the
    # boards' 5 ms ticks put bursts of more than 4 frames on the wire)
    bound_us = 1_000 * -(-row["queue_high_water"] // 4)
    assert lat["frames"] == tel.client.frames_received and 0 < lat["mean"] <= lat["max"] <= bound_us
    usb = row["usb_host"]
    assert usb["out_reports"] == row["out_reports"] == row["tx_frames"]   # one frame per OUT report
    assert usb["in_reports"] == row["in_reports"]
    # one OUT report leaves per 1 ms frame: the health check writes one SDO request per expected
    # node at a frame boundary, so the last of them waits one frame per request
    assert usb["out_wait_us"]["max"] == 1_000 * len(tel.client.expected_nodes)
    assert 0 < usb["out_wait_us"]["mean"] < usb["out_wait_us"]["max"]


def test_a_passive_monitor_stays_on_the_can_bus_and_the_gateway_unpowered(tmp_path):
    """serve's BusMonitor listens on a CAN handle of its own; the gateway, bus-powered from the
    PC's USB, is off and takes nothing from the bus."""
    sc = parse_scenario(DEFAULT_SCENARIO.read_text(), str(DEFAULT_SCENARIO))
    t = build_network(sc, host_cls=BusMonitor)
    try:
        t.scheduler.run_until(200_000)
        gw = t.boards["gateway"]
        assert not isinstance(t.client.bus, HidGatewayBus) and t.usb_port is None
        assert t.host_can_bus is t.client.bus and t.client.frames_received > 0
        assert gw.rx_frames == 0 and t.board_summary()["gateway"]["state"] == "OFF"
    finally:
        t.close()


def test_send_refuses_frames_the_gateway_cannot_carry(tel):
    """Extended ids and remote frames raise CanOperationError; nothing reaches the gateway."""
    gw, bus = tel.boards["gateway"], tel.client.bus
    with pytest.raises(can.CanOperationError):
        bus.send(can.Message(arbitration_id=0x1234, is_extended_id=True, data=b"\1"))
    with pytest.raises(can.CanOperationError):
        bus.send(can.Message(arbitration_id=0x100, is_extended_id=False, is_remote_frame=True))
    tel.scheduler.run_until(tel.scheduler.now_us + 5_000)
    assert gw.out_reports == 0


def test_send_many_packs_four_frames_per_report(tel):
    """Nine frames go in three OUT reports and reach the bus in order."""
    gw, bus = tel.boards["gateway"], tel.client.bus
    seen = []
    tel.network.add_tap(lambda m: seen.append(m.arbitration_id) if 0x640 <= m.arbitration_id < 0x650 else None)
    bus.send_many([can.Message(arbitration_id=0x640 + i, data=bytes([i]), is_extended_id=False) for i in range(9)])
    tel.scheduler.run_until(tel.scheduler.now_us + 5_000)
    assert seen == [0x640 + i for i in range(9)] and gw.out_reports == 3


def test_gateway_reset_and_removal_as_scenario_faults(tel):
    """board_reset on the gateway: it boots again and the host hears the boards again; then
    remove_board: the host hears nothing and every board goes LOST in its view. malformed_frame
    does not apply to the gateway."""
    from host.faults import check_fault
    from host.scenario import Fault

    tel.client.power_on()
    now = tel.scheduler.now_us
    tel.inject_fault(Fault(at_s=0, kind="board_reset", board="gateway"), now)
    gw = tel.boards["gateway"]
    assert gw.reset_count == 1 and gw.reset_cause == "watchdog" and gw.rx_frames == 0
    n0 = tel.client.frames_received
    tel.scheduler.run_until(now + 100_000)
    assert tel.client.frames_received > n0 + 50 and gw.status_name == "CONFIGURED"
    tel.inject_fault(Fault(at_s=0, kind="remove_board", board="gateway"), tel.scheduler.now_us)
    n1 = tel.client.frames_received
    tel.scheduler.run_until(tel.scheduler.now_us + 3_000_000)
    rows = tel.board_summary()
    assert tel.client.frames_received == n1 and rows["gateway"]["state"] == "OFF"
    assert {name: r["state"] for name, r in rows.items() if name != "gateway"} == {
        name: "LOST" for name in ("ra-axis", "dec-axis", "ra-reader", "dec-reader", "focus")}
    with pytest.raises(ValueError, match="malformed_frame needs board"):
        check_fault("malformed_frame", "gateway", {})


class _ListOnlyDevice:
    """A hidapi-shaped device with only ``read`` (a list of ints) and ``write``: what a real
    ``hid.device`` offers (no ``sim_read_report``)."""

    def __init__(self, dev):
        self._dev = dev

    def read(self, max_length, timeout_ms=0):
        return self._dev.read(max_length, timeout_ms)

    def write(self, buff):
        return self._dev.write(buff)

    def error(self):
        return self._dev.error()


def _frames_read_by(reader: str):
    """Power on, stop the client's reading, let 30 ms of IN reports pile up at the USB host, then
    read them with ``reader``; returns (what was read, the frames on the wire in that span)."""
    sc = parse_scenario(DEFAULT_SCENARIO.read_text(), str(DEFAULT_SCENARIO))
    t = build_network(sc)
    try:
        assert t.client.power_on().ok
        bus = t.client.bus
        bus.set_rx_callback(None)                 # nobody reads: reports wait in the USB host
        t.scheduler.run_until(t.scheduler.now_us + 3_000)   # frames already queued at the gateway
        bus.drain_frames()
        wire = []
        t.network.add_tap(lambda m: wire.append((m.arbitration_id, bytes(m.data))))
        t.scheduler.run_until(t.scheduler.now_us + 30_000)
        if reader == "drain_frames":
            got = [(f[0], bytes(f[1]), f[2]) for f in bus.drain_frames()]
        else:
            rbus = bus if reader == "recv" else HidGatewayBus(_ListOnlyDevice(bus.device))
            got = []
            msg = rbus.recv(0)
            while msg is not None:
                got.append((msg.arbitration_id, bytes(msg.data), round(msg.timestamp * 1e6)))
                msg = rbus.recv(0)
            if rbus is not bus:
                rbus.shutdown()
        return got, wire
    finally:
        t.close()


def test_drain_frames_gives_what_recv_gives():
    """The client's receive path (``drain_frames``: tuples, no ``can.Message``) hands out the same
    frames, in the same order and with the same gateway timestamps, as python-can ``recv(0)``
    one by one, on the in-process device (``sim_read_report``) and on one offering only
    hidapi's ``read``; and those are the frames the wire carried, minus the host's own."""
    drained, wire = _frames_read_by("drain_frames")
    received, wire2 = _frames_read_by("recv")
    listed, _ = _frames_read_by("list-device")
    assert wire == wire2 and len(drained) > 10
    assert drained == received == listed
    # the reports of the last USB frame may still be in flight: a prefix of the wire's frames
    others = [f for f in wire if f[0] not in _HOST_IDS]
    assert [f[:2] for f in drained] == others[:len(drained)] and len(others) - len(drained) <= 4
