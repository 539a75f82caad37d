"""The EDS files: generated from one table, loadable by canopen, ranges equal to the firmware's."""

from __future__ import annotations

import configparser

import canopen
import pytest

from boards.control import IncrementalPI
from boards.endat import POSITION_BITS
from bus import protocol as proto
from bus.eds import eds_path, load_od
from bus.eds.generate import check_all, render_eds
from bus.eds.objects import (EMCY_CODES, KINDS, PDO_FRAMES, REVISION, SOFTWARE_VERSION,
                             VENDOR_ID, serial_number)

KIND_NODES = [(k, n) for k in KINDS for n in KINDS[k].nodes]


def test_shipped_eds_files_equal_the_generated_ones():
    """Every shipped EDS is byte-identical to what bus/eds/objects.py generates."""
    assert check_all() == {}


@pytest.mark.parametrize("kind,node", KIND_NODES)
def test_every_eds_loads_with_canopen_import_od(kind, node):
    """canopen.import_od reads each EDS; identity, device type and node-relative COB-IDs resolve."""
    od = canopen.import_od(str(eds_path(kind)), node)
    k = KINDS[kind]
    for index in (0x1000, 0x1001, 0x1018):          # CiA 301 mandatory objects
        assert index in od
    assert od[0x1000].default == int(proto.DEVICE_TYPE_OF_NODE[node]) << 16
    assert od[0x1018][1].default == VENDOR_ID
    assert od[0x1018][2].default == int(proto.DEVICE_TYPE_OF_NODE[node])
    assert od[0x1018][3].default == REVISION
    assert od[0x1018][4].default == serial_number(k.product_code, node)
    assert od[0x100A].default == SOFTWARE_VERSION
    assert od[0x1014].default == 0x80 + node
    assert (od[0x1200][1].default, od[0x1200][2].default) == (0x600 + node, 0x580 + node)
    assert od[0x1017].default == proto.HEARTBEAT_PERIOD_US // 1000
    assert od.device_information.product_number == k.product_code
    assert od.device_information.nr_of_TXPDO == len(k.tpdos)


@pytest.mark.parametrize("kind", list(KINDS))
def test_eds_sections_are_cia306_shaped(kind):
    """Plain configparser (as other CANopen tools) reads the file; object lists match the sections."""
    cp = configparser.ConfigParser(interpolation=None)
    cp.optionxform = str
    cp.read_string(render_eds(kind))
    for section in ("FileInfo", "DeviceInfo", "MandatoryObjects", "OptionalObjects",
                    "ManufacturerObjects"):
        assert cp.has_section(section)
    listed = []
    for section in ("MandatoryObjects", "OptionalObjects", "ManufacturerObjects"):
        n = int(cp[section]["SupportedObjects"])
        listed += [int(cp[section][str(i)], 16) for i in range(1, n + 1)]
    objects = [int(s, 16) for s in cp.sections() if len(s) == 4 and s[0].isdigit()]
    assert sorted(listed) == sorted(objects)
    for s in cp.sections():
        if "sub" in s or (len(s) == 4 and cp[s].get("ObjectType") == "0x7"):
            assert cp[s]["AccessType"] in ("ro", "rw", "rww", "const", "wo")


def test_pdo_maps_decode_the_paper_frames_like_bus_protocol():
    """canopen's PDO decoding (from the EDS mapping) gives the fields bus/protocol.py encoded."""
    net = canopen.Network()
    node = canopen.RemoteNode(1, load_od("axis_controller", 1))
    net.add_node(node)
    node.tpdo.read(from_od=True)
    node.rpdo.read(from_od=True)
    frame = proto.encode_axis_status(mode=5, flags=0b1010, u_q15=-1234, qei_counts=0xABCDEF)
    node.tpdo[1].on_message(0x181, frame, 0.0)
    got = {v.name.split(".")[-1]: v.raw for v in node.tpdo[1].map}
    assert got == {"device_type": 0x01, "mode": 5, "flags": 0b1010, "u_q15": -1234,
                   "qei_counts": 0xABCDEF}
    assert node.tpdo[1].cob_id == 0x181 and node.tpdo[2].cob_id == 0x281
    cmd = proto.encode_axis_command(cmd=6, direction=-1, value=-123456)
    node.rpdo[1].on_message(0x201, cmd, 0.0)
    got = {v.name.split(".")[-1]: v.raw for v in node.rpdo[1].map}
    assert got == {"device_type": 0x10, "cmd": 6, "direction": -1, "reserved_b3": 0,
                   "value": -123456}                      # byte 0: the host sent it
    assert node.rpdo[2].cob_id == 0x283          # LIMIT from the RA reader's TPDO2
    reader = canopen.RemoteNode(3, load_od("position_reader", 3))
    net.add_node(reader)
    reader.tpdo.read(from_od=True)
    lim = proto.encode_limit(axis=0, flags=3, pos_counts=(1 << 29) - 5)
    reader.tpdo[2].on_message(0x283, lim, 0.0)
    assert [v.raw for v in reader.tpdo[2].map] == [0x02, 0, 3, 0, (1 << 29) - 5]


@pytest.mark.parametrize("kind", list(KINDS))
def test_every_pdo_maps_exactly_eight_bytes(kind):
    """Each mapping covers the 8 data bytes in order, byte 0 = device type."""
    od = load_od(kind, KINDS[kind].nodes[0])
    for base in (0x1600, 0x1A00):
        for index in range(base, base + 4):
            if index not in od:
                continue
            entries = [od[index][s].default for s in range(1, od[index][0].default + 1)]
            assert sum(e & 0xFF for e in entries) == 64
            assert (entries[0] >> 8) & 0xFF == 1 and (entries[0] >> 16) >= 0x3000


def _acc(kind, index, sub):
    e = KINDS[kind].object(index).entry(sub)
    return e.low, e.high


def test_ranges_equal_what_todays_firmware_accepts():
    """The EDS LowLimit/HighLimit are today's firmware limits (one source for phase 2)."""
    value = next(f for f in proto.FRAMES["AXIS_COMMAND"].fields if f.name == "value")
    assert _acc("axis_controller", 0x2000, 1) == (0, value.hi)       # SET_KP: value >= 0
    assert _acc("axis_controller", 0x2000, 2) == (0, value.hi)
    lo, hi = _acc("axis_controller", 0x2000, 3)                      # u_max in (0, 1]
    IncrementalPI(1e-4, 1e-5, lo / 32767)
    IncrementalPI(1e-4, 1e-5, hi / 32767)
    with pytest.raises(ValueError):
        IncrementalPI(1e-4, 1e-5, (lo - 1) / 32767)
    with pytest.raises(ValueError):
        IncrementalPI(1e-4, 1e-5, (hi + 1) / 32767)
    lo, hi = _acc("axis_controller", 0x2000, 4)                      # p in [0, 1)
    assert lo == 0 and hi / 32767 < 1.0 <= (hi + 1) / 32767
    for sub in range(1, 6):                                          # presets: within the VELOCITY bound
        assert _acc("axis_controller", 0x2001, sub) == (0, proto.AXIS_COMMAND_VALUE_RANGES[
            proto.AxisCommand.VELOCITY][1])
    half = 1 << (POSITION_BITS - 1)
    assert _acc("position_reader", 0x2100, 1) == (-half, half - 1)
    assert _acc("position_reader", 0x2101, 0) == (0, (1 << POSITION_BITS) - 1)
    pos = next(f for f in proto.FRAMES["FOCUS_STATUS"].fields if f.name == "pos_halfsteps")
    assert _acc("focus_controller", 0x2200, 1) == (0, pos.hi)
    assert _acc("focus_controller", 0x2200, 2) == (1, 1_000_000)
    assert _acc("focus_controller", 0x2201, 0) == (0, proto.ADC_MAX)


def test_emcy_codes_cover_every_project_fault_code():
    """Every FAULT code of bus/protocol.py has an EMCY code (FAULT_CLEARED is CiA 301's error
    reset, EMCY 0x0000, not an error code of its own); codes are unique."""
    assert {e.fault_code for e in EMCY_CODES.values()} >= {int(c) for c in proto.FaultCode} - {
        int(proto.FaultCode.FAULT_CLEARED)}
    codes = [e.code for e in EMCY_CODES.values()]
    assert len(codes) == len(set(codes)) and 0 not in codes


def test_pdo_frames_are_frames_of_bus_protocol():
    """Each PDO carries a frame of the one frame table, on the identifier bus/protocol.py (and
    so the DBC) gives it: the wiring follows the COB-ID plan."""
    from bus.eds.objects import protocol_cob_id
    for f in PDO_FRAMES:
        assert f in proto.FRAMES
    for k in KINDS.values():
        for p in k.tpdos + k.rpdos:
            assert p.frame in PDO_FRAMES
            for n in k.nodes:
                cob = p.cob_id_for(n)
                assert protocol_cob_id(p.frame, cob) == cob
                assert proto.frame_kind(cob) == p.frame


def test_docs_canopen_tables_are_the_generated_ones():
    """docs/canopen.md shows the COB-ID plan, objects and EMCY codes exactly as the table has them."""
    from pathlib import Path

    from bus.eds.objects import cob_id_plan_markdown, emcy_markdown, objects_markdown
    doc = (Path(__file__).resolve().parents[1] / "docs" / "canopen.md").read_text()
    for table in (cob_id_plan_markdown(), objects_markdown(), emcy_markdown()):
        assert table in doc
    assert "the plan the wiring follows" in doc
