"""The issue-11 fault kinds on the full emulated telescope (host/bus_faults.py)."""

import pytest

from bus import protocol as p
from bus.network import BUS_OFF
from host.bus_faults import FAULT_KINDS, apply_fault
from host.network import build_network
from host.scenario import parse_scenario

SCENARIO = """\
name: kinds
seed: 1
plant: {preload: low}
faults: []
segments:
  - {name: s, axis: ra, mode: stop, duration_s: 1}
"""


@pytest.fixture
def tel():
    t = build_network(parse_scenario(SCENARIO, "kinds.yaml"))
    t.client.send_nmt(p.NmtCommand.START)          # boards boot PRE-OPERATIONAL
    # delivered: the host's frames leave through the USB gateway at the next 1 ms USB frame
    # (here t = 1 ms), then take their CAN frame time (docs/usb-gateway.md), so 2 ms, not 1 ms
    t.scheduler.run_until(2_000)
    yield t
    t.close()


def test_bus_off_fault_silences_the_board_and_counts_it(tel):
    """bus_off on ra-axis: its controller reads bus-off, its AXIS_STATUS stops appearing."""
    tel.scheduler.run_until(100_000)
    apply_fault(tel, "bus_off", tel.scheduler.now_us, board="ra-axis")
    tel.scheduler.run_until(300_000)
    ax = tel.boards["ra-axis"]
    assert ax.can.error_state == BUS_OFF and ax.can.tx_errors > 0
    n0 = tel.network.per_id.get(p.axis_status_cob_id(1), 0)
    tel.scheduler.run_until(500_000)
    assert tel.network.per_id.get(p.axis_status_cob_id(1), 0) == n0
    assert tel.network.error_state(ax.can.bus).bus_off_count == 1


def test_reader_loss_fault_makes_the_axis_report_reader_lost(tel):
    """reader_loss on ra-reader: within the reader timeout the RA axis flags READER_LOST."""
    tel.scheduler.run_until(100_000)
    apply_fault(tel, "reader_loss", tel.scheduler.now_us, board="ra-reader")
    tel.scheduler.run_until(200_000)
    assert tel.boards["ra-axis"].reader_lost == 1 and tel.boards["dec-axis"].reader_lost == 0


def test_host_loss_hides_host_frames_from_every_board(tel):
    """host_loss: a STOP_ALL the host sends (through the USB gateway, the host's node on the bus)
    reaches no board."""
    apply_fault(tel, "host_loss", tel.scheduler.now_us)
    tel.client.bus.send(__import__("can").Message(
        arbitration_id=p.stop_all_cob_id(), is_extended_id=False,
        data=p.encode_stop_all()))
    tel.scheduler.run_until(12_000)
    lost = {name: tel.network.error_state(b.can.bus).frames_lost for name, b in tel.boards.items()}
    assert lost == {**{name: 1 for name in tel.boards if name != "gateway"}, "gateway": 0}  # not its own
    assert tel.boards["gateway"].tx_frames == 2           # the fixture's NMT start, then the STOP_ALL


def test_unknown_kind_lists_the_valid_ones(tel):
    """An unknown kind fails with the list of valid kinds."""
    with pytest.raises(ValueError, match="valid: \\['babbling_node'"):
        apply_fault(tel, "nope", 0)
    assert set(FAULT_KINDS) == {"can_error", "frame_loss", "babbling_node", "bus_off",
                                "host_loss", "reader_loss"}
