"""The boards on the real emulated CAN network (bus.network + SimBus): end-to-end behaviour."""

import itertools

import can
import pytest

from boards import AxisController, AxisMode, FocusController, PositionReader
from boards.axis_controller import SLEW_ARCSEC_S
from bus import protocol as p
from bus.network import CanNetwork
from bus.scheduler import Scheduler
from bus.simbus import SimBus
from boards_fakes import ToyAxis

_chan = itertools.count()


@pytest.fixture
def net():
    s = Scheduler()
    n = CanNetwork(s, f"boards-test-{next(_chan)}")
    yield s, n
    n.close()


def test_host_commands_axis_and_reader_limit_stops_it(net):
    """Host → AXIS_COMMAND SLEW over SimBus; the RA reader's LIMIT stops the axis."""
    s, n = net
    angle_counts = [0]
    plant = ToyAxis(s)
    ax = AxisController(s, SimBus(network=n), 1, read_qei_counts=plant.qei_counts,
                        on_duties=plant.set_duties)
    rd = PositionReader(s, SimBus(network=n), 3, high_limit_deg=0.5,
                        read_position_word=lambda: int(plant.angle / (1_296_000 / 2**29)) % 2**29)
    fc = FocusController(s, SimBus(network=n), 5, on_step=lambda d: None)
    host = SimBus(network=n)
    for b in (ax, rd, fc):
        b.start()
    host.send(can.Message(arbitration_id=p.nmt_cob_id(), data=p.encode_nmt(p.NmtCommand.START),
                          is_extended_id=False))          # the boards boot PRE-OPERATIONAL
    s.run_until(1_000)
    host.send(can.Message(arbitration_id=p.axis_command_cob_id(1),
                          data=p.encode_axis_command(p.AxisCommand.SLEW, 1), is_extended_id=False))
    s.run_until(3_000_000)
    # stopped by the limit; at rest inside the limit the flag clears (LIMIT_STOP -> STOP)
    assert ax.mode in (AxisMode.LIMIT_STOP, AxisMode.STOP) and abs(plant.omega) < 5.0
    # braking starts in the reader's braking zone: the axis stops before the 0.5° limit
    assert 0.5 - 1.2 * rd.safety.braking_distance_arcsec(SLEW_ARCSEC_S) / 3600 < rd.angle_deg < 0.5
    ids = set()
    while (m := host.recv()) is not None:
        ids.add(m.arbitration_id)
    assert {0x283, 0x081, 0x181, 0x183, 0x185, 0x281, 0x701, 0x703, 0x705} <= ids
    assert 0x073 not in ids                   # LIMIT moved off the restricted 0x001-0x07F
    assert ax.malformed_frames == rd.malformed_frames == fc.malformed_frames == 0
