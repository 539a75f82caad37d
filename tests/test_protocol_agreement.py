"""docs/protocol.md, bus/schmidt.dbc and the EDS files (bus/eds) describe the same bus."""

from pathlib import Path

import canopen

from bus import protocol as P
from bus.eds import eds_path
from bus.eds.objects import EMCY_CODES, KINDS

ROOT = Path(__file__).resolve().parents[1]
DOC = (ROOT / "docs" / "protocol.md").read_text(encoding="utf-8")
DB = P.load_dbc()


def test_protocol_md_frame_sections_are_the_frame_table():
    """The frame sections of docs/protocol.md are generated from bus.protocol.FRAMES."""
    assert P.frames_markdown() in DOC
    for cob in P.COB_TABLE:                      # every identifier on the bus is documented
        assert f"0x{cob:03X}" in DOC, hex(cob)


def test_every_pdo_of_every_eds_is_a_dbc_message_with_the_same_byte_layout():
    """Each TPDO/RPDO COB-ID of each EDS (read by canopen from the shipped file) is the DBC
    message of the frame it maps, and the mapped objects cover the frame's bytes exactly as
    the DBC's signals do (start byte and length of every field)."""
    for kind in KINDS.values():
        for node_id in kind.nodes:
            od = canopen.import_od(str(eds_path(kind.name)), node_id)
            for pdos, comm_base, map_base in ((kind.tpdos, 0x1800, 0x1A00), (kind.rpdos, 0x1400, 0x1600)):
                for pdo in pdos:
                    cob = od[comm_base + pdo.number - 1][1].default & 0x7FF
                    msg = DB.get_message_by_frame_id(cob)
                    assert P.frame_kind(cob) == pdo.frame and msg.length == 8, (kind.name, hex(cob))
                    mapping = od[map_base + pdo.number - 1]
                    starts, pos = {}, 0
                    for sub in range(1, mapping[0].default + 1):
                        raw = mapping[sub].default
                        obj = od[raw >> 16][(raw >> 8) & 0xFF]
                        starts[obj.name] = (pos, raw & 0xFF)
                        pos += raw & 0xFF
                    assert pos == 64, (kind.name, pdo.frame)
                    spec = P.FRAMES[pdo.frame]
                    for f in spec.fields:
                        sig_start = f.start_byte * 8
                        assert starts[f.name][0] == sig_start, (pdo.frame, f.name)
                        dbc_names = f.flag_names if f.kind == "flags" else (
                            [P.AXIS_COMMAND_VALUE_SIGNALS[c][0] for c in P.AxisCommand]
                            if pdo.frame == "AXIS_COMMAND" and f.name == "value" else [f.dbc_name or f.name])
                        for name in dbc_names:
                            assert sig_start <= msg.get_signal_by_name(name).start < sig_start + starts[f.name][1]


def test_emcy_codes_agree_between_protocol_md_the_eds_table_and_the_dbc():
    """Every EMCY code of bus/eds/objects.py is in docs/protocol.md's fault code table, its
    project code is a value of the DBC's EMCY fault_code signal, and the EMCY COB-IDs of the
    EDS (0x1014) are the DBC's EMCY messages."""
    for e in EMCY_CODES.values():
        assert f"| {e.fault_code} | {e.name} | 0x{e.code:04X}" in DOC, e.name
    for kind in KINDS.values():
        if kind.name == "host":
            continue
        for node_id in kind.nodes:
            od = canopen.import_od(str(eds_path(kind.name)), node_id)
            cob = od[0x1014].default
            msg = DB.get_message_by_frame_id(cob)
            assert msg.name == f"EMCY_{P.NODE_NAME[node_id]}"
            choices = msg.get_signal_by_name("fault_code").choices
            assert {e.fault_code for e in EMCY_CODES.values()} <= set(choices)
            hb = DB.get_message_by_frame_id(P.heartbeat_cob_id(node_id))
            assert hb.length == 1 and od[0x1017].default == P.HEARTBEAT_PERIOD_US // 1000
