"""The project's host client through the USB-HID gateway: HostClient on a python-can bus made of
HID reports (host/gateway_bus.py) over the in-process hid.device, the gateway on the bus of the
five boards built by host.network.build_network."""

import can
import pytest

from boards.usb_gateway import UsbGateway
from bus import hid_reports as R
from bus import protocol as p
from bus.simbus import SimBus
from host import hid_device
from host.client import HostClient
from host.gateway_bus import HidGatewayBus
from host.monitor import BusMonitor
from host.network import build_network
from host.scenario import parse_scenario
from host.serve import DEFAULT_SCENARIO


@pytest.fixture
def tel():
    sc = parse_scenario(DEFAULT_SCENARIO.read_text(), str(DEFAULT_SCENARIO))
    t = build_network(sc, host_cls=BusMonitor)      # the network's own host node only listens
    gw = UsbGateway(t.scheduler, SimBus(network=t.network))
    usb = hid_device.SimUsb()
    usb.plug(gw, advance=None)                      # the client reads from scheduler callbacks
    gw.start()
    dev = hid_device.device(usb=usb)
    dev.open(0x04D8, 0x003F)
    bus = HidGatewayBus(dev)
    yield t, gw, bus
    bus.shutdown()
    t.close()


def test_health_check_and_tracking_through_the_gateway(tel):
    """HostClient over HID: the five boards answer the power-on SDO health check; TRACK reaches the RA axis
    and its status frames come back through IN reports."""
    t, gw, bus = tel
    client = HostClient(bus=bus, scheduler=t.scheduler, preset_rates_arcsec_s=t.client.preset_rates_arcsec_s,
                        arcsec_per_count=t.client.arcsec_per_count)
    health = client.power_on()
    assert health.ok, health.missing
    assert set(health.answered) == {"ra-axis", "dec-axis", "ra-reader", "dec-reader", "focus"}
    client.command_axis("ra", "track")
    t.scheduler.run_until(t.scheduler.now_us + 500_000)
    assert client.axes["ra"].mode_name == "TRACK"
    assert client.malformed_frames == 0 and bus.malformed_reports == 0 and bus.lost_reports == 0
    # every frame the client sent (health check, identity/parameter SDOs, NMT start, its
    # heartbeat, TRACK) went through the gateway, as the network's monitor saw them on the wire
    from_host = [c for c in t.client.frames_by_id if c == 0 or 0x600 < c < 0x680 or c == 0x710 or c == 0x201]
    assert gw.tx_frames == sum(t.client.frames_by_id[c] for c in from_host)
    assert gw.rx_dropped == 0 and gw.out_malformed == 0
    assert t.client.commands_seen == {"NMT START": 1, "AXIS_COMMAND TRACK": 1}   # as on the wire


def test_send_refuses_frames_the_gateway_cannot_carry(tel):
    """Extended ids and remote frames raise CanOperationError; nothing reaches the gateway."""
    t, gw, bus = tel
    with pytest.raises(can.CanOperationError):
        bus.send(can.Message(arbitration_id=0x1234, is_extended_id=True, data=b"\1"))
    with pytest.raises(can.CanOperationError):
        bus.send(can.Message(arbitration_id=0x100, is_extended_id=False, is_remote_frame=True))
    t.scheduler.run_until(t.scheduler.now_us + 5_000)
    assert gw.out_reports == 0


def test_send_many_packs_four_frames_per_report(tel):
    """Nine frames go in three OUT reports and reach the bus in order."""
    t, gw, bus = tel
    seen = []
    t.network.add_tap(lambda m: seen.append(m.arbitration_id) if 0x640 <= m.arbitration_id < 0x650 else None)
    bus.send_many([can.Message(arbitration_id=0x640 + i, data=bytes([i]), is_extended_id=False) for i in range(9)])
    t.scheduler.run_until(t.scheduler.now_us + 5_000)
    assert seen == [0x640 + i for i in range(9)] and gw.out_reports == 3
