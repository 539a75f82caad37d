"""The conformance host's heartbeat, measured where it matters: its arrival at the devices.

The host beats every second of the devices' clock or of the wall clock, also while it is still
taking a backlog of received frames (host/conformance/link.py). A beat sent then carries the
backlog's stamp, older than the devices' time; the CI guest's run of session 11 failed
``emcy.heartbeat_lost`` on it (an EMCY "1720 ms" after a beat that had reached the node ≈ 200 ms
later than its stamp said). ``Link.arrival_s`` gives the stamp of the first frame received after
the send. Checked here against the emulator's own bus, read by a second, passive python-can bus
on the same channel (each frame's end on the wire, simulated µs), which the link never sees: a
slow, bursty emulator (``rate``) with the host stalled 3 s (``host_stall``) so backlogs happen.
"""

from __future__ import annotations

from pathlib import Path

import can
import cantools
import pytest

from host.conformance.emulator import open_emulator_link
from host.conformance.link import HOST_NODE, DeviceClock

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "tests" / "guest" / "conform-serve.yaml"


def _clock() -> DeviceClock:
    # the periods from the DBC (GenMsgCycleTime) and the EDS producer heartbeat (1000 ms), as
    # the suite's own Conformance.device_clock does, read here with cantools directly
    db = cantools.database.load_file(str(ROOT / "bus" / "schmidt.dbc"))
    return DeviceClock({m.frame_id: m.cycle_time / 1000 for m in db.messages if m.cycle_time}, 1.0)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_arrival_of_a_beat_sent_in_a_backlog_is_its_time_at_the_devices(seed):
    link = open_emulator_link(SCENARIO, rate=0.3, seed=seed, device_clock=_clock(),
                              host_stall=(0x700 + HOST_NODE, 3.0))
    sniffer = can.Bus(interface="schmidt-sim", channel=link.bus.channel)
    try:
        link.send(0x000, bytes((0x01, 0x00)))        # NMT start all: the PDO streams run
        for _ in range(40):
            link.now()                               # the host's stamps: it may be busy there
            link.wait(0.25)
        on_wire = []                                 # (end of frame s, cob) as the bus carried them
        while (m := sniffer.recv(0.0)) is not None:
            on_wire.append((m.timestamp, m.arbitration_id))
    finally:
        sniffer.shutdown()
        link.close()
    sent_cobs = {f.cob_id for f in link.sent}
    dev_wire = [t for t, cob in on_wire if cob not in sent_cobs]   # the devices' frames, in order
    assert len(dev_wire) == len(link.frames)
    beats = [f for f in link.sent if f.cob_id == 0x700 + HOST_NODE]
    beats_wire = [t for t, cob in on_wire if cob == 0x700 + HOST_NODE]
    assert len(beats) == len(beats_wire) >= 10

    def clock_at(t_wire: float) -> float:
        # the link's clock had it read every frame on the wire up to t_wire: the largest stamp
        # so far (the clock's own accuracy is tests/test_conformance_device_clock.py's subject)
        return max((f.t for f, w in zip(link.frames, dev_wire) if w <= t_wire), default=0.0)

    truth = [clock_at(w) for w in beats_wire]
    # the case exists: some beats went out in a backlog, stamped far behind the devices
    assert max(tr - f.t for f, tr in zip(beats, truth)) > 0.2
    jitter = link.clock.pdo_jitter_s                # documented largest queueing delay (2 ms)
    res = link.clock.resolution_s()                 # 10 ms PDOs + 2 × jitter (DeviceClock)
    assert res == pytest.approx(0.014)
    checked = 0
    for f, tr, w in zip(beats, truth, beats_wire):
        if w > dev_wire[-1] - 0.1:
            continue                                 # no frame after it yet
        arr = link.arrival_s(f)
        # frames queued at the same moment as the beat may win arbitration over it, and each
        # steps the clock by its stream's period: at most the clock's resolution below; the
        # first frame sent after the beat is on the wire within a period + jitter of a stream
        # heard then (the 10 ms PDOs)
        assert tr - res - 1e-9 <= arr <= tr + 0.010 + jitter + 1e-9, (f.t, arr, tr)
        checked += 1
    assert checked >= 10
    with pytest.raises(ValueError, match="not sent on this link"):
        link.arrival_s(link.frames[0])
