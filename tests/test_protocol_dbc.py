"""Specification: bus/schmidt.dbc and the struct codecs of bus.protocol describe the same frames."""

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bus import protocol as p

DB = p.load_dbc()


def field_strategy(f):
    """Values the encoder passes through unchanged (cantools rejects anything wider)."""
    if f.kind == "enum" and f.enum is not None:
        return st.sampled_from(list(f.enum))
    if f.kind == "flags":
        return st.integers(0, (1 << len(f.flag_names)) - 1)
    return st.integers(f.lo, f.hi)


def device_types(spec, node):
    if spec.sender == "host":
        return [p.DeviceType.HOST]
    return [p.DEVICE_TYPE_OF_NODE[node]]


def frame_strategy(cob):
    """(cob_id, decoded tuple) for one message of the protocol."""
    _, spec, node = p.COB_TABLE[cob]
    parts = {f.name: field_strategy(f) for f in spec.fields}
    if "device_type" in spec.tuple_type._fields:
        parts["device_type"] = st.sampled_from(device_types(spec, node))
    return st.fixed_dictionaries(parts).map(lambda d: spec.tuple_type(**d))


ALL_FRAMES = st.sampled_from(sorted(p.COB_TABLE)).flatmap(
    lambda cob: st.tuples(st.just(cob), frame_strategy(cob)))


def to_signals(cob, frame):
    """Our decoded tuple -> raw DBC signal values."""
    return p.dbc_signals(cob, frame)


def encode_ours(cob, frame):
    spec = p.COB_TABLE[cob][1]
    return spec.encode(*frame)


def test_dbc_message_set_equals_protocol_frame_set():
    """The DBC has exactly one message per protocol COB-ID, named as frame_name() says."""
    assert {m.frame_id: m.name for m in DB.messages} == {
        cob: p.frame_name(cob) for cob in p.COB_TABLE}
    assert all(m.length == p.COB_TABLE[m.frame_id][1].dlc and not m.is_extended_frame
               for m in DB.messages)
    assert {m.length for m in DB.messages} == {1, 2, 8}      # heartbeat, NMT, the rest


def test_dbc_file_is_generated_from_frame_table():
    """bus/schmidt.dbc is the output of bus.protocol.dbc_text() (regenerate, don't hand-edit)."""
    assert p.DBC_PATH.read_text() == p.dbc_text()


def test_dbc_scaling_of_physical_signals():
    """The DBC gives physical scaling: control effort in duty, VELOCITY value in arcsec/s."""
    msg = DB.get_message_by_name("AXIS_STATUS_RA")
    assert msg.get_signal_by_name("control_effort").scale == pytest.approx(1 / 32767)
    assert msg.get_signal_by_name("control_effort").unit == "duty"
    data = p.encode_axis_command(p.AxisCommand.VELOCITY, 1, 15_041)
    decoded = DB.decode_message(p.axis_command_cob_id(1), data)
    assert decoded["velocity"] == pytest.approx(15.041)
    assert DB.get_message_by_name("AXIS_STATUS_RA").cycle_time == 10


@settings(max_examples=600, deadline=None)
@given(ALL_FRAMES)
def test_our_encoding_decodes_identically_with_cantools(cob_frame):
    """Bytes from our encoder decode with cantools to the same raw field values."""
    cob, frame = cob_frame
    data = encode_ours(cob, frame)
    assert len(data) == p.COB_TABLE[cob][1].dlc
    got = DB.decode_message(cob, data, decode_choices=False, scaling=False)
    assert got == to_signals(cob, frame)


@settings(max_examples=600, deadline=None)
@given(ALL_FRAMES)
def test_cantools_encoding_decodes_identically_with_ours(cob_frame):
    """Bytes encoded by cantools decode with our codec to the same tuple, byte for byte equal."""
    cob, frame = cob_frame
    data = DB.encode_message(cob, to_signals(cob, frame), scaling=False, strict=False)
    assert p.decode(cob, data) == frame
    assert encode_ours(cob, frame) == data


def test_dbc_fixes_the_device_type_byte_and_the_firmware_value_ranges():
    """Byte 0 has the one value the sender puts there; AXIS_COMMAND values have the firmware's
    accepted ranges (OPEN_LOOP |duty| <= 1, gains >= 0)."""
    for cob, (name, spec, node) in p.COB_TABLE.items():
        msg = DB.get_message_by_frame_id(cob)
        if spec.device_type_byte:
            sig = msg.get_signal_by_name("device_type")
            dt = p.DeviceType.HOST if spec.sender == "host" else p.DEVICE_TYPE_OF_NODE[node]
            assert (sig.minimum, sig.maximum) == (int(dt), int(dt)), name
        else:
            assert "device_type" not in [s.name for s in msg.signals], name
    cmd = DB.get_message_by_frame_id(p.axis_command_cob_id(1))
    assert (cmd.get_signal_by_name("open_loop_duty").minimum,
            cmd.get_signal_by_name("open_loop_duty").maximum) == (-1, 1)
    assert cmd.get_signal_by_name("kp").minimum == 0 and cmd.get_signal_by_name("ki").minimum == 0
