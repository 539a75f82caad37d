"""Specification of the bus.protocol codecs: layouts, identifiers, encode rules, decode errors."""

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bus import protocol as p
from bus.errors import ConfigurationError, EncodeError, MalformedFrame


def test_cob_ids_match_architecture_table():
    """COB-IDs are function code + node id as in docs/protocol.md (CANopen pre-defined set)."""
    assert p.nmt_cob_id() == 0x000 and p.stop_all_cob_id() == 0x190
    assert (p.limit_cob_id(3), p.limit_cob_id(4)) == (0x283, 0x284)
    assert [p.emcy_cob_id(n) for n in range(1, 6)] == [0x081, 0x082, 0x083, 0x084, 0x085]
    assert (p.sdo_request_cob_id(5), p.sdo_response_cob_id(1)) == (0x605, 0x581)
    assert (p.axis_status_cob_id(1), p.axis_status_cob_id(2)) == (0x181, 0x182)
    assert (p.position_cob_id(3), p.position_cob_id(4)) == (0x183, 0x184)
    assert p.focus_status_cob_id() == 0x185
    assert (p.axis_aux_cob_id(1), p.axis_aux_cob_id(2)) == (0x281, 0x282)
    assert (p.axis_command_cob_id(1), p.axis_command_cob_id(2)) == (0x201, 0x202)
    assert p.focus_command_cob_id() == 0x205
    assert p.heartbeat_cob_id(5) == 0x705 and p.heartbeat_cob_id(p.NODE_HOST) == 0x710


def test_cob_id_for_wrong_node_is_a_configuration_error():
    """Asking for a frame a node does not send (AXIS_STATUS of a reader) is refused."""
    with pytest.raises(ConfigurationError):
        p.axis_status_cob_id(3)
    with pytest.raises(ConfigurationError):
        p.position_cob_id(1)


def test_frame_names():
    """frame_name gives the DBC message name, and a stable name for unknown ids."""
    assert p.frame_name(0x181) == "AXIS_STATUS_RA"
    assert p.frame_name(0x184) == "POSITION_DEC"
    assert p.frame_name(0x083) == "EMCY_RA_READER"
    assert p.frame_name(0x000) == "NMT" and p.frame_name(0x190) == "STOP_ALL"
    assert p.frame_name(0x123) == "UNKNOWN_0x123"


def test_axis_status_layout():
    """AXIS_STATUS: dt 1, mode, flags, u_q15 i16 LE, qei_counts u24 LE."""
    data = p.encode_axis_status(p.AxisMode.TRACK, 0b0011, -2, 0x123456)
    assert data == bytes([0x01, 5, 3, 0xFE, 0xFF, 0x56, 0x34, 0x12])
    assert p.decode_axis_status(data) == (p.AxisMode.TRACK, 3, -2, 0x123456)


def test_layouts_of_every_frame():
    """Each frame's bytes follow the architecture table."""
    assert p.encode_stop_all(target_node=3) == bytes([0x10, 3, 3, 0, 0, 0, 0, 0])
    assert p.encode_nmt(p.NmtCommand.RESET_NODE, 0) == bytes([0x81, 0])
    assert p.encode_limit(p.Axis.DEC, 0b101, 0x1ABCDEF0) == bytes([2, 1, 5, 0, 0xF0, 0xDE, 0xBC, 0x1A])
    assert p.encode_emcy(0x7300, 0x81, p.FaultCode.ENDAT_CRC, 0x203, 7) == \
        bytes([0x00, 0x73, 0x81, 2, 3, 2, 7, 0])
    assert p.encode_position(0b1000, 0x0102, 5) == bytes([2, 8, 2, 1, 5, 0, 0, 0])
    assert p.encode_focus_status(1, 1023, -1, 0x12345) == bytes([3, 1, 0xFF, 3, 0xFF, 0xFF, 0x45, 0x23])
    assert p.decode_focus_status(p.encode_focus_status(0x10, 0, -40_000, -1)) == (0x10, 0, -32768, 0xFFFF)
    assert p.encode_axis_aux(7, 0x201, 3, -1) == bytes([1, 7, 1, 2, 3, 0, 0xFF, 0xFF])
    assert p.encode_axis_command(p.AxisCommand.VELOCITY, -1, 15_041) == \
        bytes([0x10, 6, 0xFF, 0]) + (15_041).to_bytes(4, "little")
    assert p.encode_focus_command(p.FocusCommand.MOVE_TO, 1000) == \
        bytes([0x10, 2, 0, 0]) + (1000).to_bytes(4, "little")
    assert p.encode_heartbeat(p.NodeState.OPERATIONAL) == bytes([5])
    assert p.encode_heartbeat(p.NodeState.PRE_OPERATIONAL) == bytes([127])


def test_encoders_saturate_quantities_and_wrap_counters():
    """clamp fields saturate, wrap fields wrap (module doc rule)."""
    assert p.decode_axis_status(p.encode_axis_status(0, 0, 99_999, -1)) == (0, 0, 32767, 0xFFFFFF)
    assert p.decode_axis_status(p.encode_axis_status(0, 0, -99_999, 1 << 24)).u_q15 == -32767
    assert p.decode_axis_aux(p.encode_axis_aux(256, 2000, -5, 40_000)) == (0, 1023, 0, 32767)
    assert p.decode_position(p.encode_position(0, 70_000, (1 << 29) + 5)) == (0, 65535, 5)
    assert p.decode_emcy(p.encode_emcy(0x2300, 3, 3, 1 << 20, 70_000))[3:] == (0xFFFF, 0xFFFF)
    assert p.decode_axis_command(p.encode_axis_command(6, 1, 1 << 40)).value == (1 << 31) - 1


@pytest.mark.parametrize("call", [
    lambda: p.encode_axis_status(9, 0, 0, 0),
    lambda: p.encode_axis_status(0, 16, 0, 0),
    lambda: p.encode_axis_status(0, 0, 0.5, 0),
    lambda: p.encode_axis_command(10, 1, 0),
    lambda: p.encode_axis_command(6, 2, 0),
    lambda: p.encode_focus_command(5, 0),
    lambda: p.encode_stop_all(0, 1),
    lambda: p.encode_nmt(3, 0),
    lambda: p.encode_emcy(0x10000, 0, 1),
    lambda: p.encode_emcy(0x1000, 0, 13),
    lambda: p.encode_heartbeat(1),
    lambda: p.encode_limit(2, 0, 0),
])
def test_encoders_refuse_invalid_enums_flags_and_non_integers(call):
    """Invalid enumerations, undefined flag bits and floats raise EncodeError (not MalformedFrame)."""
    with pytest.raises(EncodeError) as info:
        call()
    assert not isinstance(info.value, MalformedFrame)
    assert isinstance(info.value, ValueError)


def test_wrong_dlc_is_malformed():
    """A frame that is not 8 bytes is MalformedFrame(field='dlc')."""
    with pytest.raises(MalformedFrame) as info:
        p.decode_axis_status(b"\x01\x00\x00")
    assert info.value.field == "dlc" and info.value.frame == "AXIS_STATUS"
    assert "AXIS_STATUS" in str(info.value) and "8 bytes" in str(info.value)


def test_wrong_device_type_is_malformed():
    """Byte 0 must be the sender's device type."""
    data = bytearray(p.encode_axis_status(0, 0, 0, 0))
    data[0] = 0x02
    with pytest.raises(MalformedFrame) as info:
        p.decode_axis_status(bytes(data))
    assert info.value.field == "device_type" and info.value.got == 2


def test_enum_out_of_range_is_malformed():
    """Unknown mode / command / state values are MalformedFrame naming the field."""
    cases = [(p.decode_axis_status, 1, 1, 9, "mode"),
             (p.decode_axis_command, 0x10, 1, 10, "cmd"),
             (p.decode_focus_command, 0x10, 1, 5, "cmd"),
             (p.decode_emcy, 0, 3, 13, "fault_code"),
             (p.decode_limit, 2, 1, 2, "axis"),
             (p.decode_stop_all, 0x10, 1, 4, "cmd")]
    for decoder, dt, index, value, field in cases:
        data = bytearray(8)
        data[0] = dt
        data[index] = value
        with pytest.raises(MalformedFrame) as info:
            decoder(bytes(data))
        assert info.value.field == field, decoder
    for data, field in ((bytes([1]), "state"), (bytes([5, 0]), "dlc")):
        with pytest.raises(MalformedFrame) as info:
            p.decode_heartbeat(data)
        assert info.value.field == field
    for data, field in ((bytes([3, 0]), "cmd"), (bytes([1, 200]), "target_node"), (b"\x01", "dlc")):
        with pytest.raises(MalformedFrame) as info:
            p.decode_nmt(data)
        assert info.value.field == field


def test_narrow_fields_out_of_range_are_malformed():
    """A 29-bit position or 10-bit ADC value with high bits set is malformed."""
    with pytest.raises(MalformedFrame, match="pos_counts"):
        p.decode_position(bytes([2, 0, 0, 0, 0, 0, 0, 0x20]))
    with pytest.raises(MalformedFrame, match="adc_a"):
        p.decode_axis_aux(bytes([1, 0, 0, 4, 0, 0, 0, 0]))


def test_decode_dispatch_and_sender_device_type():
    """decode(cob_id, data) picks the codec by identifier."""
    hb = p.encode_heartbeat(p.NodeState.OPERATIONAL)
    assert p.decode(p.heartbeat_cob_id(1), hb).state == p.NodeState.OPERATIONAL
    with pytest.raises(MalformedFrame, match="dlc"):
        p.decode(p.heartbeat_cob_id(3), hb + b"\x00")
    with pytest.raises(MalformedFrame, match="cob_id"):
        p.decode(0x7FF, hb)
    assert "HEARTBEAT_RA_AXIS" in p.format_frame(0x701, hb)
    assert "MALFORMED" in p.format_frame(0x701, b"\x01")


@given(st.binary(min_size=0, max_size=9), st.sampled_from(sorted(p.COB_TABLE)))
def test_decoders_never_raise_anything_but_malformed_frame(data, cob):
    """Arbitrary bytes either decode or raise MalformedFrame — nothing else."""
    try:
        frame = p.decode(cob, data)
    except MalformedFrame:
        return
    spec = p.COB_TABLE[cob][1]
    assert isinstance(frame, spec.tuple_type)
