"""host/uhid_gateway.py's translation between uhid events and the simulated USB host, on a
SOCK_SEQPACKET socket pair standing in for /dev/uhid (the real device is tested in the QEMU
guest: tests/test_usb_gateway_guest.py). Events are packed here from include/uapi/linux/uhid.h."""

import socket
import struct

import pytest

from bus import hid_reports as R
from bus import protocol as p
from host.scenario import parse_scenario
from host.serve import DEFAULT_SCENARIO
from host.uhid_gateway import Uhid, UhidGateway, main

# include/uapi/linux/uhid.h, written out independently of host/uhid_gateway.py
CREATE2, INPUT2, START, OPEN, OUTPUT, GET_REPORT, GET_REPORT_REPLY, SET_REPORT, SET_REPORT_REPLY = \
    11, 12, 2, 4, 6, 9, 10, 13, 14


def kernel_output(data):
    return struct.pack("<I", OUTPUT) + data.ljust(4096, b"\0") + struct.pack("<HB", len(data), 1)


@pytest.fixture
def rig():
    from host.monitor import BusMonitor
    from host.network import build_network
    sc = parse_scenario(DEFAULT_SCENARIO.read_text(), str(DEFAULT_SCENARIO))
    tel = build_network(sc, host_cls=BusMonitor)
    kern, user = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
    user.setblocking(False)
    gw = UhidGateway(tel, Uhid.from_fd(user.detach()))
    yield tel, gw, kern
    gw.close()
    kern.close()


def drain(kern):
    out = []
    kern.setblocking(False)
    while True:
        try:
            out.append(kern.recv(8192))
        except BlockingIOError:
            return out


def test_create2_then_ping_round_trip_as_uhid_events(rig):
    """CREATE2 carries the USB ids and descriptor; OPEN starts polling; an OUTPUT event with a
    PING gives INPUT2 events with the five boards' heartbeats; GET/SET_REPORT are answered."""
    tel, gw, kern = rig
    (create,) = drain(kern)
    t, name, phys, uniq, rd_size, bus, vid, pid, ver, country = struct.unpack_from("<I128s64s64sHHIIII", create)
    assert (t, bus, vid, pid) == (CREATE2, 3, 0x04D8, 0x003F) and name.startswith(b"ARIES")
    assert create[4 + 128 + 64 + 64 + 20:][:rd_size][:3] == bytes([0x06, 0x00, 0xFF])
    kern.send(struct.pack("<IQ", START, 0))
    kern.send(struct.pack("<I", OPEN))
    gw.handle_events()
    sched = tel.scheduler
    sched.run_until(sched.now_us + 50_000)
    drain(kern)
    out = R.encode_report(R.KIND_OUT, [(0x000, p.encode_nmt(p.NmtCommand.START))])   # NMT start
    kern.send(kernel_output(b"\0" + out))          # hidraw: report number 0, then the report
    gw.handle_events()
    sched.run_until(sched.now_us + 25_000)
    ids = set()
    for ev in drain(kern):
        typ, size = struct.unpack_from("<IH", ev)
        assert typ == INPUT2 and size == 64
        ids |= {f.arbitration_id for f in R.decode_report(ev[6:6 + size], R.KIND_IN).frames}
    assert {p.axis_status_cob_id(1), p.axis_status_cob_id(2), p.position_cob_id(3),
            p.position_cob_id(4)} <= ids                  # the nodes are OPERATIONAL: PDOs flow
    kern.send(struct.pack("<IIBB", GET_REPORT, 77, 0, 0))
    kern.send(struct.pack("<IIBBH", SET_REPORT, 78, 0, 0, 65) + b"\0\x09" + bytes(63))
    kern.send(struct.pack("<IIBB", GET_REPORT, 79, 5, 0))
    gw.handle_events()
    r1, r2, r3 = drain(kern)
    typ, rid, err, size = struct.unpack_from("<IIHH", r1)
    assert (typ, rid, err, size) == (GET_REPORT_REPLY, 77, 0, 65) and r1[12] == 0
    st = R.decode_status(r1[13:13 + 64])
    assert st.tx_frames == 1 and st.node_id == 0x10 and st.out_malformed == 0
    assert struct.unpack("<IIH", r2) == (SET_REPORT_REPLY, 78, 5)      # bad command: EIO
    assert struct.unpack_from("<IIH", r3) == (GET_REPORT_REPLY, 79, 5)  # no report 5: EIO
    assert gw.gateway.out_malformed == 1


def test_missing_uhid_is_one_clear_line(capsys, tmp_path):
    """No /dev/uhid: exit status 2 and one line naming the device and what is needed."""
    assert main(["--uhid", str(tmp_path / "uhid")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "uhid" in err[0] and "modprobe uhid" in err[0]
