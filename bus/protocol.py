"""The schmidt-fil CAN frame protocol (paper §3.4): identifiers, enums and fast codecs.

Every frame is a CAN 2.0A data frame: 11-bit identifier, DLC 8, byte 0 = the **sender's**
device type (the paper: "the data word size per board is 8 bytes, first byte representing the
device type"). Multi-byte fields are little-endian. The COB-ID is a function code plus the
sender's node id (commands: plus the *addressed* node id); use the ``*_cob_id`` functions, never
inline arithmetic.

This module never imports python-can: codecs are separate from transport. ``bus/schmidt.dbc``
describes the same frames for cantools (tests check both agree).

Rules
-----
Decoders (``decode_*``) raise :class:`bus.errors.MalformedFrame` naming frame, field and the
expectation when

* the length is not 8 bytes (``field="dlc"``),
* byte 0 is not the expected device type (``field="device_type"``),
* an enumerated field (command, mode, state, cause, axis, direction, fault code) is out of range,
* a narrow value in a wider slot exceeds its width (29-bit positions, 10-bit ADC counts).

Reserved bytes ("zero" in the table) are written as zero and ignored on receive; undefined flag
bits are ignored on receive.

Encoders (``encode_*``) take plain ``int`` s (``IntEnum`` members are ints) and treat values by
field kind:

* ``enum`` and ``flags`` fields (and ids): an invalid value raises
  :class:`bus.errors.EncodeError` (a bug in the sender, not line noise);
* ``wrap`` fields (counters that wrap in hardware: ``qei_counts`` u24, ``pos_counts`` 29-bit,
  ``seq`` u8, ``uptime_s`` u16, the focus ``enc_counts`` u16) are reduced modulo 2**width;
* ``clamp`` fields (quantities and error counters: ``u_q15`` ±32767, ``qei_delta`` i16, ADC
  counts 0..1023, ``value`` i32, ``pos_halfsteps`` i16, u16 error counters) saturate at their
  limits;
* a non-integer (e.g. float) value raises :class:`bus.errors.EncodeError`.

:data:`FRAMES` describes every frame (fields, ranges, kinds, DBC names and scaling); the DBC,
the tests' Hypothesis strategies and ``docs/protocol.md`` are derived from or checked against it.
"""

from __future__ import annotations

import struct
from enum import IntEnum, IntFlag
from functools import lru_cache
from pathlib import Path
from typing import Any, Callable, Final, NamedTuple

from bus.errors import EncodeError, MalformedFrame
from bus.units import Q15_FULL_SCALE  # noqa: F401  (re-exported: bus.protocol.Q15_FULL_SCALE)

#: Integer arguments of the codecs and COB-ID helpers: any value, checked by the codec itself
#: (``EncodeError``/``MalformedFrame`` naming the frame and field). Annotated ``Any``, not
#: ``int``, so that the compiled build (bus/_native.py) accepts the same arguments as the source
#: (a float or a numpy integer reaches the codec's own check instead of a bare ``TypeError``).
_Int = Any

# ------------------------------------------------------------------------------------------------
# Nodes, device types, function codes
# ------------------------------------------------------------------------------------------------


class NodeId(IntEnum):
    """CAN node ids of the boards (architecture table)."""

    RA_AXIS = 1        #: RA axis controller, dsPIC30F3011
    DEC_AXIS = 2       #: DEC axis controller
    RA_READER = 3      #: RA EnDat position reader, PIC18F4480
    DEC_READER = 4     #: DEC EnDat position reader
    FOCUS = 5          #: focus controller, PIC18F4431
    # -- issue 12: motor tachometers and auxiliary encoders (paper §3.2, §3.4) --
    TACH_RA_1 = 6      #: tachometer of RA motor A (CP-850 on the motor shaft)
    TACH_RA_2 = 7      #: tachometer of RA motor B
    TACH_DEC_1 = 8     #: tachometer of DEC motor A
    TACH_DEC_2 = 9     #: tachometer of DEC motor B
    AUX_RA = 0x0A      #: RA auxiliary encoder (Gurley A25S through 1:10.8)
    AUX_DEC = 0x0B     #: DEC auxiliary encoder
    # -- issue 12, room nodes (display, dome, weather) --
    DISPLAY = 0x0C     #: digital display unit (§3.4)
    DOME = 0x0D        #: dome controller (§5.2, tested in the lab on RS232)
    WEATHER = 0x0E     #: weather station (§5.2, tested in the lab on RS232)
    # -- issue 12: axis velocity readers (the friction-roller encoder of §2.2 on its own node) --
    VEL_RA = 0x0F      #: RA axis velocity reader (Gurley 8×60 through the 1:24.5 friction roller)
    HOST = 0x10        #: USB-to-CAN host node, PIC18F4550
    VEL_DEC = 0x11     #: DEC axis velocity reader


NODE_RA_AXIS: Final = NodeId.RA_AXIS
NODE_DEC_AXIS: Final = NodeId.DEC_AXIS
NODE_RA_READER: Final = NodeId.RA_READER
NODE_DEC_READER: Final = NodeId.DEC_READER
NODE_FOCUS: Final = NodeId.FOCUS
NODE_HOST: Final = NodeId.HOST

AXIS_NODES: Final = (NodeId.RA_AXIS, NodeId.DEC_AXIS)
READER_NODES: Final = (NodeId.RA_READER, NodeId.DEC_READER)
#: The room nodes of issue 12 (display unit, dome controller, weather station).
ROOM_NODES: Final = (NodeId.DISPLAY, NodeId.DOME, NodeId.WEATHER)
TACH_NODES: Final = (NodeId.TACH_RA_1, NodeId.TACH_RA_2, NodeId.TACH_DEC_1, NodeId.TACH_DEC_2)
AUX_NODES: Final = (NodeId.AUX_RA, NodeId.AUX_DEC)
VEL_NODES: Final = (NodeId.VEL_RA, NodeId.VEL_DEC)
#: Every board node of the protocol (a network built from a scenario may use a subset:
#: ``boards.registry.NETWORKS``).
BOARD_NODES: Final = (NodeId.RA_AXIS, NodeId.DEC_AXIS, NodeId.RA_READER, NodeId.DEC_READER, NodeId.FOCUS,
               *TACH_NODES, *AUX_NODES, *ROOM_NODES, *VEL_NODES)
ALL_NODES: Final = BOARD_NODES + (NodeId.HOST,)


class DeviceType(IntEnum):
    """Byte 0 of every frame: the sender's device type."""

    AXIS_CONTROLLER = 0x01
    POSITION_READER = 0x02
    FOCUS_CONTROLLER = 0x03
    TACHOMETER = 0x04      #: issue 12: motor tachometer (CP-850)
    AUX_ENCODER = 0x05     #: issue 12: auxiliary absolute encoder (A25S)
    DISPLAY = 0x06         #: issue 12: digital display unit
    DOME = 0x07            #: issue 12: dome controller
    WEATHER = 0x08         #: issue 12: weather station
    AXIS_VELOCITY = 0x09   #: issue 12: axis velocity reader (friction-roller encoder)
    HOST = 0x10


#: Device type of each node.
DEVICE_TYPE_OF_NODE: Final[dict[int, DeviceType]] = {
    NodeId.RA_AXIS: DeviceType.AXIS_CONTROLLER,
    NodeId.DEC_AXIS: DeviceType.AXIS_CONTROLLER,
    NodeId.RA_READER: DeviceType.POSITION_READER,
    NodeId.DEC_READER: DeviceType.POSITION_READER,
    NodeId.FOCUS: DeviceType.FOCUS_CONTROLLER,
    NodeId.DISPLAY: DeviceType.DISPLAY,
    NodeId.DOME: DeviceType.DOME,
    NodeId.WEATHER: DeviceType.WEATHER,
    **{n: DeviceType.TACHOMETER for n in TACH_NODES},
    **{n: DeviceType.AUX_ENCODER for n in AUX_NODES},
    **{n: DeviceType.AXIS_VELOCITY for n in VEL_NODES},
    NodeId.HOST: DeviceType.HOST,
}

#: Short node names used in frame names (``AXIS_STATUS_RA``, ``FAULT_RA_READER``) and the DBC.
NODE_NAME: Final[dict[int, str]] = {
    NodeId.RA_AXIS: "RA_AXIS", NodeId.DEC_AXIS: "DEC_AXIS", NodeId.RA_READER: "RA_READER",
    NodeId.DEC_READER: "DEC_READER", NodeId.FOCUS: "FOCUS",
    NodeId.DISPLAY: "DISPLAY", NodeId.DOME: "DOME", NodeId.WEATHER: "WEATHER",
    NodeId.TACH_RA_1: "TACH_RA_1", NodeId.TACH_RA_2: "TACH_RA_2", NodeId.TACH_DEC_1: "TACH_DEC_1",
    NodeId.TACH_DEC_2: "TACH_DEC_2", NodeId.AUX_RA: "AUX_RA", NodeId.AUX_DEC: "AUX_DEC",
    NodeId.VEL_RA: "VEL_RA", NodeId.VEL_DEC: "VEL_DEC",
    NodeId.HOST: "HOST",
}

FC_NMT: Final = 0x000          #: CANopen NMT (CiA 301), host → all
FC_EMCY: Final = 0x080         #: CANopen EMCY (replaces today's FAULT)
FC_LIMIT: Final = 0x280        #: reader TPDO2 (was 0x070 + node: 0x001-0x07F is restricted in CiA 301)
FC_STOP_ALL: Final = 0x190     #: host TPDO1: 0x180 + host node 0x10 (was HOST_BROADCAST 0x000 cmd 3)
FC_SDO_TX: Final = 0x580       #: SDO server → client (answers)
FC_SDO_RX: Final = 0x600       #: SDO client → server (requests)
FC_STATUS: Final = 0x180       #: AXIS_STATUS (axes), POSITION (readers), FOCUS_STATUS (focus)
FC_COMMAND: Final = 0x200      #: AXIS_COMMAND (to axes), FOCUS_COMMAND (to focus)
FC_AUX: Final = 0x280
FC_HEARTBEAT: Final = 0x700    #: CiA 301 heartbeat / boot-up, 1 byte NMT state

#: Nominal periods, µs (event-driven frames are absent).
AXIS_STATUS_PERIOD_US: Final = 10_000
AXIS_AUX_PERIOD_US: Final = 10_000
POSITION_PERIOD_US: Final = 10_000
FOCUS_STATUS_PERIOD_US: Final = 250_000
HEARTBEAT_PERIOD_US: Final = 1_000_000
LIMIT_REPEAT_US: Final = 100_000
# issue 12, room nodes (assumed periods: docs/protocol.md)
DISPLAY_STATUS_PERIOD_US: Final = 1_000_000
DOME_STATUS_PERIOD_US: Final = 250_000
WEATHER_STATUS_PERIOD_US: Final = 1_000_000
#: issue 12: one TACH_STATUS per tachometer per 5 ms (the controllers' 5 ms tick, §3.3; the
#: issue's bus-load figure assumes one frame per board per 5 ms).
TACH_STATUS_PERIOD_US: Final = 5_000
#: issue 12: one AUX_POSITION per auxiliary encoder per 10 ms (as POSITION, §3.4's 10 ms samples).
AUX_POSITION_PERIOD_US: Final = 10_000
#: issue 12: one AXIS_VELOCITY per axis velocity reader per 10 ms (its ISR period; §3.4's 10 ms
#: samples, as POSITION).
AXIS_VELOCITY_PERIOD_US: Final = 10_000


# ------------------------------------------------------------------------------------------------
# Enums and flags
# ------------------------------------------------------------------------------------------------


class BroadcastCommand(IntEnum):
    """``STOP_ALL`` byte 1 (the one command left of HOST_BROADCAST; PING is an SDO upload, RESET
    an NMT reset node, docs/canopen.md)."""

    STOP_ALL = 3


class NmtCommand(IntEnum):
    """NMT byte 0: command specifier (CiA 301 §7.2.8.3.1)."""

    START = 0x01
    STOP = 0x02
    PRE_OPERATIONAL = 0x80
    RESET_NODE = 0x81
    RESET_COMMUNICATION = 0x82


class ResetCause(IntEnum):
    """Reset cause (object 0x2F00:3 of every board)."""

    POWER_ON = 0
    WATCHDOG = 1
    SOFTWARE = 2


class Axis(IntEnum):
    """``LIMIT`` byte 1."""

    RA = 0
    DEC = 1


class FaultCode(IntEnum):
    """The project's fault code: ``EMCY`` byte 3 (was ``FAULT`` byte 1). 0 = a CANopen error with no
    project code (heartbeat lost); 7-12 from issue 11 (FAULT_CLEARED = the EMCY error reset)."""

    NONE = 0
    MALFORMED_FRAME = 1
    ENDAT_CRC = 2
    OVER_CURRENT = 3
    LIMIT_STOP = 4
    WATCHDOG = 5
    STEP_LOSS = 6    #: focus: half-steps commanded but not seen on the motor encoder
    COMMAND_REFUSED = 7  #: a command outside its documented limits; detail = reason << 8 | cmd
    BRAKE_CUT = 8        #: braking supervisor cut the duty (axis did not slow down); detail |ω| ″/s
    READER_LOST = 9      #: axis: position reader silent (detail 1) or reporting invalid (2)
    HOST_TIMEOUT = 10    #: axis: host watchdog expired, controlled stop; detail = timeout ms
    FAULT_CLEARED = 11   #: the fault condition whose code is in ``detail`` has cleared
    OVERSPEED = 12       #: axis faster than the overspeed limit (e.g. OPEN_LOOP): braking stop; detail |ω| ″/s


class AxisMode(IntEnum):
    """``AXIS_STATUS`` byte 1: the axis controller's mode."""

    STOP = 0
    SLEW = 1
    SET = 2
    GUIDE = 3
    FINE = 4
    TRACK = 5
    VELOCITY = 6
    OPEN_LOOP = 7
    LIMIT_STOP = 8


class AxisCommand(IntEnum):
    """``AXIS_COMMAND`` byte 1."""

    STOP = 0
    SLEW = 1
    SET = 2
    GUIDE = 3
    FINE = 4
    TRACK = 5
    VELOCITY = 6     #: value = rate, milli-arcsec/s
    OPEN_LOOP = 7    #: value = duty, Q15 (±32767 = ±100 %)
    SET_KP = 8       #: value = gain × 1e6, gain in duty/(arcsec/s)
    SET_KI = 9       #: value = gain × 1e6, same scaling as SET_KP


class FocusCommand(IntEnum):
    """``FOCUS_COMMAND`` byte 1."""

    STOP = 0
    STEP = 1
    MOVE_TO = 2
    HOLD = 3   #: motor power off, regenerative holding
    FREE = 4   #: control power off


class NodeState(IntEnum):
    """``HEARTBEAT`` byte 0: the NMT state (CiA 301 §7.2.8.3.2)."""

    BOOT = 0                  #: boot-up message
    STOPPED = 4
    OPERATIONAL = 5
    PRE_OPERATIONAL = 127


class LimitFlags(IntFlag):
    """``LIMIT`` byte 2."""

    LOW_SOFT_LIMIT = 1
    HIGH_SOFT_LIMIT = 2
    POSITION_INVALID = 4
    LOW_NEAR = 8       #: within the braking distance of the highest commanded rate of the low limit
    HIGH_NEAR = 16     #: the same for the high limit (boards/safety.py approach zone)


class AxisStatusFlags(IntFlag):
    """``AXIS_STATUS`` byte 2."""

    LIMIT_STOP = 1
    ANTI_WINDUP = 2
    OVER_CURRENT = 4
    FAULT = 8


class PositionFlags(IntFlag):
    """``POSITION`` byte 1."""

    LOW_LIMIT = 1
    HIGH_LIMIT = 2
    CRC_ERROR = 4
    INVALID = 8
    LOW_NEAR = 16      #: as LimitFlags.LOW_NEAR
    HIGH_NEAR = 32     #: as LimitFlags.HIGH_NEAR


class FocusFlags(IntFlag):
    """``FOCUS_STATUS`` byte 1."""

    MOVING = 1
    HOLDING = 2
    INDEX_SEEN = 4
    POWER_OFF = 8
    STEP_LOSS = 16   #: missed half-steps detected since the last FOCUS_STATUS (latched)


# -- issue 12, room nodes: enums and flags ------------------------------------------------------


class DisplayFlags(IntFlag):
    """``DISPLAY_STATUS`` byte 1: which inputs the display showed as stale (dashes) at its last
    refresh."""

    RA_POSITION_STALE = 1
    DEC_POSITION_STALE = 2
    RA_AXIS_STALE = 4
    DEC_AXIS_STALE = 8


class DomeCommand(IntEnum):
    """``DOME_COMMAND`` byte 1."""

    STOP = 0
    FOLLOW = 1     #: slit azimuth follows the telescope (POSITION frames)
    GOTO = 2       #: value = azimuth, centi-degrees 0..35999
    PARK = 3       #: go to the park azimuth (0x2400:4) and stay


class DomeMode(IntEnum):
    """``DOME_STATUS`` byte 1."""

    IDLE = 0
    FOLLOW = 1
    GOTO = 2
    PARK = 3


class DomeFlags(IntFlag):
    """``DOME_STATUS`` byte 2."""

    MOVING = 1
    ON_TARGET = 2          #: |target - azimuth| within the deadband
    PARKED = 4             #: PARK reached the park azimuth
    POSITION_STALE = 8     #: FOLLOW without fresh POSITION frames of both axes: holding


class WeatherFlags(IntFlag):
    """``WEATHER_STATUS`` byte 1 (thresholds: the station's 0x2500 objects)."""

    HIGH_WIND = 1
    RAIN = 2


#: Absolute encoder resolution: positions are 29-bit, 2**29 counts per revolution.
POS_COUNTS_PER_REV: Final = 1 << 29
ADC_MAX: Final = 1023

# ------------------------------------------------------------------------------------------------
# COB-IDs
# ------------------------------------------------------------------------------------------------


def _check_node(kind: str, node: _Int, allowed: tuple) -> int:
    if node not in allowed:
        from bus.errors import ConfigurationError
        raise ConfigurationError(
            f"{kind} frames exist for nodes {[int(n) for n in allowed]}, not node {node!r}")
    return int(node)


def nmt_cob_id() -> int:
    """COB-ID of CANopen ``NMT`` (0x000, highest priority; host → all)."""
    return FC_NMT


def stop_all_cob_id() -> int:
    """COB-ID of ``STOP_ALL`` (0x190: the host's TPDO1, consumed by every board with motion)."""
    return FC_STOP_ALL


def limit_cob_id(node: _Int) -> int:
    """COB-ID of ``LIMIT`` sent by reader ``node`` (3 or 4): 0x280 + node (its TPDO2)."""
    return FC_LIMIT + _check_node("LIMIT", node, READER_NODES)


def emcy_cob_id(node: _Int) -> int:
    """COB-ID of ``EMCY`` sent by board ``node`` (1..5): 0x080 + node."""
    return FC_EMCY + _check_node("EMCY", node, BOARD_NODES)


def sdo_request_cob_id(node: _Int) -> int:
    """COB-ID of an SDO request (client → server) to ``node``: 0x600 + node."""
    return FC_SDO_RX + _check_node("SDO", node, BOARD_NODES)


def sdo_response_cob_id(node: _Int) -> int:
    """COB-ID of an SDO response (server → client) from ``node``: 0x580 + node."""
    return FC_SDO_TX + _check_node("SDO", node, BOARD_NODES)


def axis_status_cob_id(node: _Int) -> int:
    """COB-ID of ``AXIS_STATUS`` sent by axis controller ``node`` (1 or 2): 0x180 + node."""
    return FC_STATUS + _check_node("AXIS_STATUS", node, AXIS_NODES)


def position_cob_id(node: _Int) -> int:
    """COB-ID of ``POSITION`` sent by reader ``node`` (3 or 4): 0x180 + node."""
    return FC_STATUS + _check_node("POSITION", node, READER_NODES)


def focus_status_cob_id(node: _Int = NodeId.FOCUS) -> int:
    """COB-ID of ``FOCUS_STATUS`` (0x185)."""
    return FC_STATUS + _check_node("FOCUS_STATUS", node, (NodeId.FOCUS,))


def axis_aux_cob_id(node: _Int) -> int:
    """COB-ID of ``AXIS_AUX`` sent by axis controller ``node`` (1 or 2): 0x280 + node."""
    return FC_AUX + _check_node("AXIS_AUX", node, AXIS_NODES)


def axis_command_cob_id(node: _Int) -> int:
    """COB-ID of ``AXIS_COMMAND`` addressed to axis controller ``node`` (1 or 2): 0x200 + node."""
    return FC_COMMAND + _check_node("AXIS_COMMAND", node, AXIS_NODES)


def focus_command_cob_id(node: _Int = NodeId.FOCUS) -> int:
    """COB-ID of ``FOCUS_COMMAND`` (0x205)."""
    return FC_COMMAND + _check_node("FOCUS_COMMAND", node, (NodeId.FOCUS,))


# -- issue 12, room nodes: COB-IDs ---------------------------------------------------------------


def display_status_cob_id(node: _Int = NodeId.DISPLAY) -> int:
    """COB-ID of ``DISPLAY_STATUS`` (0x18C, the display's TPDO1)."""
    return FC_STATUS + _check_node("DISPLAY_STATUS", node, (NodeId.DISPLAY,))


def dome_status_cob_id(node: _Int = NodeId.DOME) -> int:
    """COB-ID of ``DOME_STATUS`` (0x18D, the dome's TPDO1)."""
    return FC_STATUS + _check_node("DOME_STATUS", node, (NodeId.DOME,))


def dome_command_cob_id(node: _Int = NodeId.DOME) -> int:
    """COB-ID of ``DOME_COMMAND`` (0x20D, the dome's RPDO1)."""
    return FC_COMMAND + _check_node("DOME_COMMAND", node, (NodeId.DOME,))


def weather_status_cob_id(node: _Int = NodeId.WEATHER) -> int:
    """COB-ID of ``WEATHER_STATUS`` (0x18E, the weather station's TPDO1)."""
    return FC_STATUS + _check_node("WEATHER_STATUS", node, (NodeId.WEATHER,))


def heartbeat_cob_id(node: _Int) -> int:
    """COB-ID of the CiA ``HEARTBEAT`` of ``node`` (1..5 or the host 0x10): 0x700 + node."""
    return FC_HEARTBEAT + _check_node("HEARTBEAT", node, ALL_NODES)


# ------------------------------------------------------------------------------------------------
# Decoded frames
# ------------------------------------------------------------------------------------------------


class Nmt(NamedTuple):
    cmd: NmtCommand
    target_node: int        #: 0 = all nodes


class StopAll(NamedTuple):
    cmd: BroadcastCommand
    target_node: int        #: 0 = all nodes


class Limit(NamedTuple):
    axis: Axis
    flags: int              #: LimitFlags bits
    pos_counts: int         #: 0 .. 2**29-1


class Emcy(NamedTuple):
    error_code: int         #: CiA 301 error code (0x0000 = error reset), bus.eds.objects.EMCY_CODES
    error_register: int     #: object 0x1001
    fault_code: FaultCode   #: the project's fault code (error reset: of the cleared error)
    detail: int             #: code-specific (error reset: the cleared error code)
    count: int              # type: ignore[assignment] #: occurrences of this error since reset (saturating)


class AxisStatus(NamedTuple):
    mode: AxisMode
    flags: int              #: AxisStatusFlags bits
    u_q15: int              #: control effort, ±32767 = ±100 % duty
    qei_counts: int         #: low 24 bits of the cumulative QEI count (wraps)


class Position(NamedTuple):
    flags: int              #: PositionFlags bits
    crc_errors: int
    pos_counts: int         #: 0 .. 2**29-1, 2**29 per revolution


class FocusStatus(NamedTuple):
    flags: int              #: FocusFlags bits
    lvdt_adc: int           #: 10-bit ADC counts
    pos_halfsteps: int      #: commanded half-step counter (i16, saturating)
    enc_counts: int         #: motor encoder count, low 16 bits (the QEI's POSCNT; wraps)


class AxisAux(NamedTuple):
    seq: int                #: u8, wraps
    adc_a: int              #: 10-bit shunt ADC counts, motor A (positive direction)
    adc_b: int              #: 10-bit shunt ADC counts, motor B
    qei_delta: int          #: counts in the last 5 ms tick


class AxisCommandFrame(NamedTuple):
    cmd: AxisCommand
    direction: int          #: +1, -1 (0 allowed where direction is meaningless)
    value: int


class FocusCommandFrame(NamedTuple):
    cmd: FocusCommand
    value: int              #: half-steps


class Sdo(NamedTuple):
    command: int            #: CiA 301 SDO command specifier byte
    index: int              # type: ignore[assignment] #: object index (initiate frames; segments carry data here)
    subindex: int
    data: int               #: u32 little-endian (expedited data / size / abort code)


class Heartbeat(NamedTuple):
    state: NodeState        #: NMT state (0 = boot-up message)


# -- issue 12, room nodes: decoded frames
class DisplayStatus(NamedTuple):
    flags: int              #: DisplayFlags bits at the last refresh
    frames_received: int    #: POSITION/AXIS_STATUS frames consumed since reset, u16 (wraps)
    refreshes: int          #: display refreshes since reset, u16 (wraps)


class DomeStatus(NamedTuple):
    mode: DomeMode
    flags: int              #: DomeFlags bits
    azimuth_cdeg: int       #: slit azimuth, centi-degrees 0..35999 (N = 0, E = 9000)
    target_cdeg: int        #: target azimuth, centi-degrees 0..35999


class DomeCommandFrame(NamedTuple):
    cmd: DomeCommand
    value: int              #: GOTO: azimuth, centi-degrees


class WeatherStatus(NamedTuple):
    flags: int              #: WeatherFlags bits
    temperature_cdegc: int  #: air temperature, 0.01 degC (i16)
    humidity_cpct: int      #: relative humidity, 0.01 % (0..10000)
    wind_cm_s: int          #: wind speed, cm/s (u16)


# ------------------------------------------------------------------------------------------------
# Codecs (one struct per frame; hand-written for speed, checked against the DBC by tests)
# ------------------------------------------------------------------------------------------------

_DT_AXIS: Final = DeviceType.AXIS_CONTROLLER
_DT_READER: Final = DeviceType.POSITION_READER
_DT_FOCUS: Final = DeviceType.FOCUS_CONTROLLER
_DT_HOST: Final = DeviceType.HOST
_DT_BY_VALUE: Final = {int(d): d for d in DeviceType}


def _table(enum_cls) -> tuple:
    """Tuple indexed by value (None for gaps) for fast int -> member lookup."""
    top = max(enum_cls)
    return tuple(enum_cls(i) if i in enum_cls._value2member_map_ else None
                 for i in range(top + 1))


_BCAST: Final = _table(BroadcastCommand)
_NMT: Final = _table(NmtCommand)
_CAUSE: Final = _table(ResetCause)
_AXIS: Final = _table(Axis)
_FAULT: Final = _table(FaultCode)
_MODE: Final = _table(AxisMode)
_ACMD: Final = _table(AxisCommand)
_FCMD: Final = _table(FocusCommand)
_STATE: Final = _table(NodeState)
_DOME_MODE: Final = _table(DomeMode)
_DCMD: Final = _table(DomeCommand)


def _enum_or_raise(table: tuple, value: _Int, frame: str, field: str, exc: type) -> Any:
    member = table[value] if 0 <= value < len(table) else None
    if member is None:
        valid = [int(m) for m in table if m is not None]
        enum_name = type(next(m for m in table if m is not None)).__name__
        raise exc(frame, field, f"{enum_name} in {valid}", value)
    return member


def _check_len(data, frame: str) -> None:
    if len(data) != 8:
        raise MalformedFrame(frame, "dlc", "8 bytes", len(data))


def _unpack(s: struct.Struct, data, frame: str, device_type) -> tuple:
    """Length check, unpack and device-type check of a frame sent by one device type (the 10 ms
    status decoders inline this for speed)."""
    _check_len(data, frame)
    fields = s.unpack(data)
    if fields[0] != device_type:
        raise _bad_type(frame, device_type, fields[0])
    return fields


def _bad_type(frame: str, expected, got: _Int) -> MalformedFrame:
    return MalformedFrame(frame, "device_type", f"{expected!r} (0x{int(expected):02X})", got)


def _not_int(frame: str, exc: Exception) -> EncodeError:
    return EncodeError(frame, "*", f"int values for every field ({exc})")


def _flags(frame: str, field: str, value: _Int, mask: _Int) -> int:
    if value & ~mask or value < 0:
        raise EncodeError(frame, field, f"flag bits within 0x{mask:02X}", value)
    return value


#: ``tuple.__new__(Cls, values)``: a NamedTuple built without its Python-level ``__new__`` (what
#: ``Cls._make`` does; the per-frame decoders use it)
_tuple_new: Final = tuple.__new__


def _clamp(v: _Int, lo: _Int, hi: _Int) -> int:
    return lo if v < lo else (hi if v > hi else v)


I32_MIN, I32_MAX = -(1 << 31), (1 << 31) - 1

# -- NMT ------------------------------------------------------------------------------------------
_S_NMT: Final = struct.Struct("<BB")


def encode_nmt(cmd: _Int, target_node: _Int = 0) -> bytes:
    """Encode CANopen ``NMT`` (0x000, DLC 2): command specifier, target node (0 = all)."""
    f = "NMT"
    _enum_or_raise(_NMT, cmd, f, "cmd", EncodeError)
    if not 0 <= target_node <= 127:
        raise EncodeError(f, "target_node", "0..127 (0 = all)", target_node)
    return _S_NMT.pack(cmd, target_node)


def decode_nmt(data) -> Nmt:
    """Decode ``NMT``; raises MalformedFrame."""
    if len(data) != 2:
        raise MalformedFrame("NMT", "dlc", "2", len(data))
    cmd, target = _S_NMT.unpack(data)
    if target > 127:
        raise MalformedFrame("NMT", "target_node", "0..127", target)
    return Nmt(_enum_or_raise(_NMT, cmd, "NMT", "cmd", MalformedFrame), target)


# -- STOP_ALL -------------------------------------------------------------------------------------
_S_STOP_ALL: Final = struct.Struct("<BBB5x")


def encode_stop_all(cmd: _Int = BroadcastCommand.STOP_ALL, target_node: _Int = 0) -> bytes:
    """Encode ``STOP_ALL`` (0x190, host TPDO1): bytes ``10 03 nn 00..``, target node (0 = all)."""
    f = "STOP_ALL"
    _enum_or_raise(_BCAST, cmd, f, "cmd", EncodeError)
    if not 0 <= target_node <= 255:
        raise EncodeError(f, "target_node", "0..255 (0 = all)", target_node)
    try:
        return _S_STOP_ALL.pack(_DT_HOST, cmd, target_node)
    except (struct.error, TypeError) as exc:
        raise _not_int(f, exc) from None


def decode_stop_all(data) -> StopAll:
    """Decode ``STOP_ALL``; raises MalformedFrame."""
    dt, cmd, target = _unpack(_S_STOP_ALL, data, "STOP_ALL", _DT_HOST)
    return StopAll(_enum_or_raise(_BCAST, cmd, "STOP_ALL", "cmd", MalformedFrame), target)


# -- LIMIT ----------------------------------------------------------------------------------------
_S_LIMIT: Final = struct.Struct("<BBBxI")
_POS_MASK: Final = (1 << 29) - 1


def encode_limit(axis: _Int, flags: _Int, pos_counts: _Int) -> bytes:
    """Encode ``LIMIT`` (0x070 + reader node): axis, LimitFlags, 29-bit position (wraps)."""
    f = "LIMIT"
    _enum_or_raise(_AXIS, axis, f, "axis", EncodeError)
    try:
        _flags(f, "flags", flags, 0x1F)
        return _S_LIMIT.pack(_DT_READER, axis, flags, pos_counts & _POS_MASK)
    except (struct.error, TypeError) as exc:
        raise _not_int(f, exc) from None


def decode_limit(data) -> Limit:
    """Decode ``LIMIT``; raises MalformedFrame."""
    dt, axis, flags, pos = _unpack(_S_LIMIT, data, "LIMIT", _DT_READER)
    if pos > _POS_MASK:
        raise MalformedFrame("LIMIT", "pos_counts", "29-bit value < 2**29", pos)
    return Limit(_enum_or_raise(_AXIS, axis, "LIMIT", "axis", MalformedFrame), flags, pos)


# -- EMCY -----------------------------------------------------------------------------------------
_S_EMCY: Final = struct.Struct("<HBBHH")


def encode_emcy(error_code: _Int, error_register: _Int, fault_code: _Int, detail: _Int = 0,
                count: _Int = 0) -> bytes:
    """Encode ``EMCY`` (0x080 + node, CiA 301 §7.2.7): error code u16, error register u8, then the
    manufacturer bytes: project FaultCode u8, detail u16, count u16 (both saturate)."""
    f = "EMCY"
    _enum_or_raise(_FAULT, fault_code, f, "fault_code", EncodeError)
    try:
        if not 0 <= error_code <= 0xFFFF:
            raise EncodeError(f, "error_code", "0..0xFFFF", error_code)
        _flags(f, "error_register", error_register, 0xFF)
        return _S_EMCY.pack(error_code, error_register, fault_code, _clamp(detail, 0, 0xFFFF),
                            _clamp(count, 0, 0xFFFF))
    except (struct.error, TypeError) as exc:
        raise _not_int(f, exc) from None


def decode_emcy(data) -> Emcy:
    """Decode ``EMCY``; raises MalformedFrame."""
    _check_len(data, "EMCY")
    code, reg, fault, detail, count = _S_EMCY.unpack(data)
    return Emcy(code, reg, _enum_or_raise(_FAULT, fault, "EMCY", "fault_code", MalformedFrame),
                detail, count)


# -- AXIS_STATUS ----------------------------------------------------------------------------------
_S_AXIS_STATUS: Final = struct.Struct("<BBBhHB")


def encode_axis_status(mode: _Int, flags: _Int, u_q15: _Int, qei_counts: _Int) -> bytes:
    """Encode ``AXIS_STATUS`` (0x180 + axis node).

    Parameters
    ----------
    mode : int
        :class:`AxisMode`.
    flags : int
        :class:`AxisStatusFlags` bits (0..15).
    u_q15 : int
        Control effort, Q15 duty; saturated to ±32767.
    qei_counts : int
        Cumulative QEI count; its low 24 bits are sent (wraps).
    """
    f = "AXIS_STATUS"
    _enum_or_raise(_MODE, mode, f, "mode", EncodeError)
    try:
        _flags(f, "flags", flags, 0x0F)
        q = qei_counts & 0xFFFFFF
        return _S_AXIS_STATUS.pack(_DT_AXIS, mode, flags,
                                   -Q15_FULL_SCALE if u_q15 < -Q15_FULL_SCALE else (Q15_FULL_SCALE if u_q15 > Q15_FULL_SCALE else u_q15),
                                   q & 0xFFFF, q >> 16)
    except (struct.error, TypeError) as exc:
        raise _not_int(f, exc) from None


def decode_axis_status(data) -> AxisStatus:
    """Decode ``AXIS_STATUS``; raises MalformedFrame."""
    if len(data) != 8:
        raise MalformedFrame("AXIS_STATUS", "dlc", "8 bytes", len(data))
    dt, mode, flags, u, lo, hi = _S_AXIS_STATUS.unpack(data)
    if dt != 1:
        raise _bad_type("AXIS_STATUS", _DT_AXIS, dt)
    if mode > 8:
        raise MalformedFrame("AXIS_STATUS", "mode", "AxisMode in 0..8", mode)
    return _tuple_new(AxisStatus, (_MODE[mode], flags, u, lo | (hi << 16)))


# -- POSITION -------------------------------------------------------------------------------------
_S_POSITION: Final = struct.Struct("<BBHI")


def encode_position(flags: _Int, crc_errors: _Int, pos_counts: _Int) -> bytes:
    """Encode ``POSITION`` (0x180 + reader node): PositionFlags, u16 crc_errors (saturates),
    29-bit absolute position (wraps)."""
    f = "POSITION"
    try:
        _flags(f, "flags", flags, 0x3F)
        return _S_POSITION.pack(_DT_READER, flags, _clamp(crc_errors, 0, 0xFFFF), pos_counts & _POS_MASK)
    except (struct.error, TypeError) as exc:
        raise _not_int(f, exc) from None


def decode_position(data) -> Position:
    """Decode ``POSITION``; raises MalformedFrame."""
    if len(data) != 8:
        raise MalformedFrame("POSITION", "dlc", "8 bytes", len(data))
    dt, flags, crc, pos = _S_POSITION.unpack(data)
    if dt != 2:
        raise _bad_type("POSITION", _DT_READER, dt)
    if pos > _POS_MASK:
        raise MalformedFrame("POSITION", "pos_counts", "29-bit value < 2**29", pos)
    return _tuple_new(Position, (flags, crc, pos))


# -- FOCUS_STATUS ---------------------------------------------------------------------------------
_S_FOCUS_STATUS: Final = struct.Struct("<BBHhH")


def encode_focus_status(flags: _Int, lvdt_adc: _Int, pos_halfsteps: _Int, enc_counts: _Int) -> bytes:
    """Encode ``FOCUS_STATUS`` (0x185): FocusFlags, LVDT ADC 0..1023, half-steps i16 (saturate),
    motor encoder count u16 (wraps: the low 16 bits, as the PIC18F4431 POSCNT register)."""
    f = "FOCUS_STATUS"
    try:
        _flags(f, "flags", flags, 0x1F)
        return _S_FOCUS_STATUS.pack(_DT_FOCUS, flags, _clamp(lvdt_adc, 0, ADC_MAX),
                                    _clamp(pos_halfsteps, -32768, 32767), enc_counts & 0xFFFF)
    except (struct.error, TypeError) as exc:
        raise _not_int(f, exc) from None


def decode_focus_status(data) -> FocusStatus:
    """Decode ``FOCUS_STATUS``; raises MalformedFrame."""
    dt, flags, lvdt, pos, enc = _unpack(_S_FOCUS_STATUS, data, "FOCUS_STATUS", _DT_FOCUS)
    if lvdt > ADC_MAX:
        raise MalformedFrame("FOCUS_STATUS", "lvdt_adc", "10-bit value 0..1023", lvdt)
    return _tuple_new(FocusStatus, (flags, lvdt, pos, enc))


# -- AXIS_AUX -------------------------------------------------------------------------------------
_S_AXIS_AUX: Final = struct.Struct("<BBHHh")


def encode_axis_aux(seq: _Int, adc_a: _Int, adc_b: _Int, qei_delta: _Int) -> bytes:
    """Encode ``AXIS_AUX`` (0x280 + axis node): seq u8 (wraps), shunt ADC counts 0..1023
    (saturate), qei_delta i16 (saturates)."""
    f = "AXIS_AUX"
    try:
        return _S_AXIS_AUX.pack(_DT_AXIS, seq & 0xFF,
                                0 if adc_a < 0 else (ADC_MAX if adc_a > ADC_MAX else adc_a),
                                0 if adc_b < 0 else (ADC_MAX if adc_b > ADC_MAX else adc_b),
                                -32768 if qei_delta < -32768 else (32767 if qei_delta > 32767 else qei_delta))
    except (struct.error, TypeError) as exc:
        raise _not_int(f, exc) from None


def decode_axis_aux(data) -> AxisAux:
    """Decode ``AXIS_AUX``; raises MalformedFrame."""
    if len(data) != 8:
        raise MalformedFrame("AXIS_AUX", "dlc", "8 bytes", len(data))
    dt, seq, a, b, d = _S_AXIS_AUX.unpack(data)
    if dt != 1:
        raise _bad_type("AXIS_AUX", _DT_AXIS, dt)
    if a > ADC_MAX:
        raise MalformedFrame("AXIS_AUX", "adc_a", "10-bit value 0..1023", a)
    if b > ADC_MAX:
        raise MalformedFrame("AXIS_AUX", "adc_b", "10-bit value 0..1023", b)
    return _tuple_new(AxisAux, (seq, a, b, d))


# -- AXIS_COMMAND ---------------------------------------------------------------------------------
_S_AXIS_COMMAND: Final = struct.Struct("<BBbxi")


def encode_axis_command(cmd: _Int, direction: _Int = 0, value: _Int = 0) -> bytes:
    """Encode ``AXIS_COMMAND`` (0x200 + axis node).

    Parameters
    ----------
    cmd : int
        :class:`AxisCommand`.
    direction : int
        +1 or -1 (0 where meaningless); anything else raises EncodeError.
    value : int
        i32, saturated. VELOCITY: milli-arcsec/s; OPEN_LOOP: duty Q15; SET_KP/SET_KI: gain × 1e6
        with the gain in duty/(arcsec/s).
    """
    f = "AXIS_COMMAND"
    _enum_or_raise(_ACMD, cmd, f, "cmd", EncodeError)
    if direction not in (-1, 0, 1):
        raise EncodeError(f, "direction", "-1, 0 or +1", direction)
    try:
        return _S_AXIS_COMMAND.pack(_DT_HOST, cmd, direction, _clamp(value, I32_MIN, I32_MAX))
    except (struct.error, TypeError) as exc:
        raise _not_int(f, exc) from None


def decode_axis_command(data) -> AxisCommandFrame:
    """Decode ``AXIS_COMMAND``; raises MalformedFrame."""
    dt, cmd, direction, value = _unpack(_S_AXIS_COMMAND, data, "AXIS_COMMAND", _DT_HOST)
    if direction not in (-1, 0, 1):
        raise MalformedFrame("AXIS_COMMAND", "direction", "-1, 0 or +1", direction)
    return AxisCommandFrame(_enum_or_raise(_ACMD, cmd, "AXIS_COMMAND", "cmd", MalformedFrame),
                            direction, value)


# -- FOCUS_COMMAND --------------------------------------------------------------------------------
_S_FOCUS_COMMAND: Final = struct.Struct("<BB2xi")


def encode_focus_command(cmd: _Int, value: _Int = 0) -> bytes:
    """Encode ``FOCUS_COMMAND`` (0x205): FocusCommand, value in half-steps (i32, saturates)."""
    f = "FOCUS_COMMAND"
    _enum_or_raise(_FCMD, cmd, f, "cmd", EncodeError)
    try:
        return _S_FOCUS_COMMAND.pack(_DT_HOST, cmd, _clamp(value, I32_MIN, I32_MAX))
    except (struct.error, TypeError) as exc:
        raise _not_int(f, exc) from None


def decode_focus_command(data) -> FocusCommandFrame:
    """Decode ``FOCUS_COMMAND``; raises MalformedFrame."""
    dt, cmd, value = _unpack(_S_FOCUS_COMMAND, data, "FOCUS_COMMAND", _DT_HOST)
    return FocusCommandFrame(_enum_or_raise(_FCMD, cmd, "FOCUS_COMMAND", "cmd", MalformedFrame), value)


# -- SDO (request 0x600 + node, response 0x580 + node) ---------------------------------------------
_S_SDO: Final = struct.Struct("<BHBI")


def encode_sdo(command: _Int, index: _Int = 0, subindex: _Int = 0, data: _Int = 0) -> bytes:
    """Encode an SDO frame in the initiate layout (CiA 301 §7.2.4.3): command specifier, index
    u16, sub-index, 4 data bytes (u32 LE). Segment frames carry 7 data bytes after byte 0 in the
    same 8 bytes."""
    try:
        return _S_SDO.pack(command, index, subindex, data)
    except (struct.error, TypeError) as exc:
        raise _not_int("SDO", exc) from None


def decode_sdo(data) -> Sdo:
    """Decode an SDO frame (any 8 bytes); raises MalformedFrame on another length."""
    _check_len(data, "SDO")
    return Sdo(*_S_SDO.unpack(data))


# -- HEARTBEAT ------------------------------------------------------------------------------------


def encode_heartbeat(state: _Int) -> bytes:
    """Encode the CiA 301 ``HEARTBEAT`` (0x700 + node, DLC 1): the NMT state (0 = boot-up)."""
    _enum_or_raise(_STATE, state, "HEARTBEAT", "state", EncodeError)
    return bytes((int(state),))


def decode_heartbeat(data) -> Heartbeat:
    """Decode ``HEARTBEAT``; raises MalformedFrame."""
    if len(data) != 1:
        raise MalformedFrame("HEARTBEAT", "dlc", "1", len(data))
    return _tuple_new(Heartbeat, (_enum_or_raise(_STATE, data[0], "HEARTBEAT", "state", MalformedFrame),))


# -- issue 12, room nodes: codecs ------------------------------------------------------------------
_S_DISPLAY_STATUS: Final = struct.Struct("<BBHH2x")
_DT_DISPLAY: Final = DeviceType.DISPLAY
_DT_DOME: Final = DeviceType.DOME
_DT_WEATHER: Final = DeviceType.WEATHER
AZIMUTH_CDEG_MAX: Final = 35_999
HUMIDITY_CPCT_MAX: Final = 10_000


def encode_display_status(flags: _Int, frames_received: _Int, refreshes: _Int) -> bytes:
    """Encode ``DISPLAY_STATUS`` (0x18C): DisplayFlags, frames received u16 and refreshes u16
    (both wrap)."""
    f = "DISPLAY_STATUS"
    try:
        _flags(f, "flags", flags, 0x0F)
        return _S_DISPLAY_STATUS.pack(_DT_DISPLAY, flags, frames_received & 0xFFFF, refreshes & 0xFFFF)
    except (struct.error, TypeError) as exc:
        raise _not_int(f, exc) from None


def decode_display_status(data) -> DisplayStatus:
    """Decode ``DISPLAY_STATUS``; raises MalformedFrame."""
    dt, flags, n, r = _unpack(_S_DISPLAY_STATUS, data, "DISPLAY_STATUS", _DT_DISPLAY)
    return _tuple_new(DisplayStatus, (flags, n, r))


_S_DOME_STATUS: Final = struct.Struct("<BBBHHx")


def encode_dome_status(mode: _Int, flags: _Int, azimuth_cdeg: _Int, target_cdeg: _Int) -> bytes:
    """Encode ``DOME_STATUS`` (0x18D): DomeMode, DomeFlags, azimuth and target in centi-degrees
    (each reduced modulo 36000: an angle wraps)."""
    f = "DOME_STATUS"
    _enum_or_raise(_DOME_MODE, mode, f, "mode", EncodeError)
    try:
        _flags(f, "flags", flags, 0x0F)
        return _S_DOME_STATUS.pack(_DT_DOME, mode, flags, azimuth_cdeg % 36_000, target_cdeg % 36_000)
    except (struct.error, TypeError) as exc:
        raise _not_int(f, exc) from None


def decode_dome_status(data) -> DomeStatus:
    """Decode ``DOME_STATUS``; raises MalformedFrame."""
    dt, mode, flags, az, tgt = _unpack(_S_DOME_STATUS, data, "DOME_STATUS", _DT_DOME)
    if az > AZIMUTH_CDEG_MAX:
        raise MalformedFrame("DOME_STATUS", "azimuth_cdeg", "0..35999", az)
    if tgt > AZIMUTH_CDEG_MAX:
        raise MalformedFrame("DOME_STATUS", "target_cdeg", "0..35999", tgt)
    return DomeStatus(_enum_or_raise(_DOME_MODE, mode, "DOME_STATUS", "mode", MalformedFrame), flags, az, tgt)


_S_DOME_COMMAND: Final = struct.Struct("<BB2xi")


def encode_dome_command(cmd: _Int, value: _Int = 0) -> bytes:
    """Encode ``DOME_COMMAND`` (0x20D): DomeCommand, value i32 (GOTO: azimuth centi-degrees;
    saturates; the dome refuses values outside 0..35999)."""
    f = "DOME_COMMAND"
    _enum_or_raise(_DCMD, cmd, f, "cmd", EncodeError)
    try:
        return _S_DOME_COMMAND.pack(_DT_HOST, cmd, _clamp(value, I32_MIN, I32_MAX))
    except (struct.error, TypeError) as exc:
        raise _not_int(f, exc) from None


def decode_dome_command(data) -> DomeCommandFrame:
    """Decode ``DOME_COMMAND``; raises MalformedFrame."""
    dt, cmd, value = _unpack(_S_DOME_COMMAND, data, "DOME_COMMAND", _DT_HOST)
    return DomeCommandFrame(_enum_or_raise(_DCMD, cmd, "DOME_COMMAND", "cmd", MalformedFrame), value)


_S_WEATHER_STATUS: Final = struct.Struct("<BBhHH")


def encode_weather_status(flags: _Int, temperature_cdegc: _Int, humidity_cpct: _Int, wind_cm_s: _Int) -> bytes:
    """Encode ``WEATHER_STATUS`` (0x18E): WeatherFlags, temperature i16 0.01 degC, humidity
    0..10000 (0.01 %), wind u16 cm/s (all saturate)."""
    f = "WEATHER_STATUS"
    try:
        _flags(f, "flags", flags, 0x03)
        return _S_WEATHER_STATUS.pack(_DT_WEATHER, flags, _clamp(temperature_cdegc, -32768, 32767),
                                      _clamp(humidity_cpct, 0, HUMIDITY_CPCT_MAX), _clamp(wind_cm_s, 0, 0xFFFF))
    except (struct.error, TypeError) as exc:
        raise _not_int(f, exc) from None


def decode_weather_status(data) -> WeatherStatus:
    """Decode ``WEATHER_STATUS``; raises MalformedFrame."""
    dt, flags, t, h, w = _unpack(_S_WEATHER_STATUS, data, "WEATHER_STATUS", _DT_WEATHER)
    if h > HUMIDITY_CPCT_MAX:
        raise MalformedFrame("WEATHER_STATUS", "humidity_cpct", "0..10000", h)
    return _tuple_new(WeatherStatus, (flags, t, h, w))


# ------------------------------------------------------------------------------------------------
# Frame table: the single description of fields, used for the DBC, tests and docs
# ------------------------------------------------------------------------------------------------


class Field(NamedTuple):
    """One field of a frame (all fields are little-endian and start on a byte boundary).

    ``lo``/``hi`` is the range the encoder accepts unchanged (and the decoder returns);
    ``kind`` is ``"enum"``, ``"flags"``, ``"wrap"``, ``"clamp"`` or ``"id"`` (see module doc).
    ``dbc_name``/``factor``/``dbc_unit`` give the DBC signal (physical = raw × factor); for
    ``flags`` the DBC has one 1-bit signal per name in ``flag_names``.
    """

    name: str
    start_byte: int
    bits: int
    signed: bool
    lo: int
    hi: int
    kind: str
    unit: str = ""
    enum: type | None = None
    flag_names: tuple = ()
    dbc_name: str | None = None
    factor: float = 1.0
    dbc_unit: str = ""
    doc: str = ""


class FrameSpec(NamedTuple):
    """One frame kind: name, function code, nodes, codec and fields (after byte 0)."""

    name: str
    function_code: int
    nodes: tuple            #: nodes the COB-ID is formed with (sender, or addressee for commands)
    sender: str             #: "node" (the node itself) or "host"
    period_us: int | None   #: nominal period; None = on event / on demand
    fields: tuple
    tuple_type: type
    encode: Callable
    decode: Callable
    doc: str
    dlc: int = 8                 #: data length (CANopen NMT 2, heartbeat 1)
    device_type_byte: bool = True  #: byte 0 is the sender's device type (False: CANopen layouts)


def _fl(names: tuple) -> tuple:
    return names


def _enum_range(e) -> tuple[int, int]:
    return min(e), max(e)


FRAMES: Final[dict[str, FrameSpec]] = {}


def _add(spec: FrameSpec) -> None:
    FRAMES[spec.name] = spec


_add(FrameSpec("NMT", FC_NMT, (None,), "host", None, (
    Field("cmd", 0, 8, False, 1, 0x82, "enum", enum=NmtCommand),
    Field("target_node", 1, 8, False, 0, 127, "id", doc="0 = all nodes"),
), Nmt, encode_nmt, decode_nmt,
    "CANopen NMT (CiA 301), host to all: start, stop, pre-operational, reset node, reset "
    "communication", dlc=2, device_type_byte=False))

_add(FrameSpec("STOP_ALL", FC_STOP_ALL, (None,), "host", None, (
    Field("cmd", 1, 8, False, 3, 3, "enum", enum=BroadcastCommand),
    Field("target_node", 2, 8, False, 0, 255, "id", doc="0 = all nodes"),
), StopAll, encode_stop_all, decode_stop_all,
    "host TPDO1 to every board with motion (their RPDO3): stop"))

_add(FrameSpec("LIMIT", FC_LIMIT, READER_NODES, "node", None, (
    Field("axis", 1, 8, False, 0, 1, "enum", enum=Axis),
    Field("flags", 2, 8, False, 0, 31, "flags", flag_names=("low_soft_limit", "high_soft_limit",
                                                             "position_invalid", "low_near", "high_near")),
    Field("pos_counts", 4, 29, False, 0, (1 << 29) - 1, "wrap", unit="counts",
          dbc_unit="counts", doc="29-bit absolute position, 2**29 per revolution"),
), Limit, encode_limit, decode_limit,
    "reader to axis controller: on change, then every 100 ms while a limit is active"))

_add(FrameSpec("EMCY", FC_EMCY, BOARD_NODES, "node", None, (
    Field("error_code", 0, 16, False, 0, 0xFFFF, "id",
          doc="CiA 301 error code, 0 = error reset (docs/canopen.md EMCY codes)"),
    Field("error_register", 2, 8, False, 0, 0xFF, "id", doc="object 0x1001"),
    Field("fault_code", 3, 8, False, 0, max(FaultCode), "enum", enum=FaultCode),
    Field("detail", 4, 16, False, 0, 0xFFFF, "clamp",
          doc="code-specific, e.g. offending COB-ID; error reset: the cleared error code"),
    Field("count", 6, 16, False, 0, 0xFFFF, "clamp", doc="occurrences since reset"),
), Emcy, encode_emcy, decode_emcy,
    "CANopen EMCY, any board to host, on event; error reset (code 0) when a condition clears",
    device_type_byte=False))

_add(FrameSpec("AXIS_STATUS", FC_STATUS, AXIS_NODES, "node", AXIS_STATUS_PERIOD_US, (
    Field("mode", 1, 8, False, 0, 8, "enum", enum=AxisMode),
    Field("flags", 2, 8, False, 0, 15, "flags", flag_names=("limit_stop", "anti_windup",
                                                             "over_current", "fault")),
    Field("u_q15", 3, 16, True, -Q15_FULL_SCALE, Q15_FULL_SCALE, "clamp", unit="duty Q15",
          dbc_name="control_effort", factor=1 / Q15_FULL_SCALE, dbc_unit="duty",
          doc="control effort U, ±32767 = ±100 % duty"),
    Field("qei_counts", 5, 24, False, 0, (1 << 24) - 1, "wrap", unit="counts", dbc_unit="counts",
          doc="low 24 bits of the cumulative QEI count"),
), AxisStatus, encode_axis_status, decode_axis_status, "axis controller to host, every 10 ms"))

_add(FrameSpec("POSITION", FC_STATUS, READER_NODES, "node", POSITION_PERIOD_US, (
    Field("flags", 1, 8, False, 0, 63, "flags", flag_names=("low_limit", "high_limit",
                                                             "crc_error", "invalid", "low_near",
                                                             "high_near")),
    Field("crc_errors", 2, 16, False, 0, 0xFFFF, "clamp", unit="reads"),
    Field("pos_counts", 4, 29, False, 0, (1 << 29) - 1, "wrap", unit="counts", dbc_unit="counts",
          doc="29-bit absolute position, 2**29 per revolution"),
), Position, encode_position, decode_position, "reader to host, every 10 ms"))

_add(FrameSpec("FOCUS_STATUS", FC_STATUS, (NodeId.FOCUS,), "node", FOCUS_STATUS_PERIOD_US, (
    Field("flags", 1, 8, False, 0, 31, "flags", flag_names=("moving", "holding", "index_seen",
                                                             "power_off", "step_loss")),
    Field("lvdt_adc", 2, 10, False, 0, ADC_MAX, "clamp", unit="ADC counts", dbc_unit="counts"),
    Field("pos_halfsteps", 4, 16, True, -32768, 32767, "clamp", unit="half-steps",
          dbc_unit="halfsteps", doc="commanded half-step counter (6.25 um each)"),
    Field("enc_counts", 6, 16, False, 0, 0xFFFF, "wrap", unit="counts", dbc_unit="counts",
          doc="motor encoder, low 16 bits of the QEI count (5 counts per half-step)"),
), FocusStatus, encode_focus_status, decode_focus_status, "focus controller to host, every 250 ms"))

_add(FrameSpec("AXIS_AUX", FC_AUX, AXIS_NODES, "node", AXIS_AUX_PERIOD_US, (
    Field("seq", 1, 8, False, 0, 255, "wrap"),
    Field("adc_a", 2, 10, False, 0, ADC_MAX, "clamp", unit="ADC counts", dbc_unit="counts",
          doc="shunt ADC, motor A (positive direction)"),
    Field("adc_b", 4, 10, False, 0, ADC_MAX, "clamp", unit="ADC counts", dbc_unit="counts",
          doc="shunt ADC, motor B"),
    Field("qei_delta", 6, 16, True, -32768, 32767, "clamp", unit="counts/tick",
          dbc_unit="counts", doc="QEI counts in the last 5 ms tick"),
), AxisAux, encode_axis_aux, decode_axis_aux, "axis controller to host, every 10 ms"))

_add(FrameSpec("AXIS_COMMAND", FC_COMMAND, AXIS_NODES, "host", None, (
    Field("cmd", 1, 8, False, 0, 9, "enum", enum=AxisCommand),
    Field("direction", 2, 8, True, -1, 1, "enum", doc="+1 / -1 (0 where meaningless)"),
    Field("value", 4, 32, True, I32_MIN, I32_MAX, "clamp",
          doc="VELOCITY: milli-arcsec/s; OPEN_LOOP: duty Q15; SET_KP/SET_KI: gain × 1e6, "
              "gain in duty/(arcsec/s)"),
), AxisCommandFrame, encode_axis_command, decode_axis_command, "host to axis controller"))

_add(FrameSpec("FOCUS_COMMAND", FC_COMMAND, (NodeId.FOCUS,), "host", None, (
    Field("cmd", 1, 8, False, 0, 4, "enum", enum=FocusCommand),
    Field("value", 4, 32, True, I32_MIN, I32_MAX, "clamp", unit="half-steps",
          dbc_unit="halfsteps"),
), FocusCommandFrame, encode_focus_command, decode_focus_command, "host to focus controller"))

_SDO_FIELDS: Final = (
    Field("command", 0, 8, False, 0, 255, "id", doc="SDO command specifier (CiA 301 7.2.4.3)"),
    Field("index", 1, 16, False, 0, 0xFFFF, "id", doc="object index (initiate and abort frames)"),
    Field("subindex", 3, 8, False, 0, 255, "id"),
    Field("data", 4, 32, False, 0, 0xFFFFFFFF, "id",
          doc="expedited data, size or abort code (u32 LE)"),
)
_add(FrameSpec("SDO_RESPONSE", FC_SDO_TX, BOARD_NODES, "node", None, _SDO_FIELDS, Sdo, encode_sdo,
               decode_sdo, "CANopen SDO server to client (the host): answers, aborts",
               device_type_byte=False))
_add(FrameSpec("SDO_REQUEST", FC_SDO_RX, BOARD_NODES, "host", None, _SDO_FIELDS, Sdo, encode_sdo,
               decode_sdo, "CANopen SDO client (the host) to server: read and write objects; the "
               "health check reads 0x1000", device_type_byte=False))

_add(FrameSpec("HEARTBEAT", FC_HEARTBEAT, ALL_NODES, "node", HEARTBEAT_PERIOD_US, (
    Field("state", 0, 8, False, 0, 127, "enum", enum=NodeState),
), Heartbeat, encode_heartbeat, decode_heartbeat,
    "CiA 301 heartbeat of every node at its 0x1017 period (1 s); boot-up message = state 0",
    dlc=1, device_type_byte=False))

# -- issue 12, room nodes: frame table ------------------------------------------------------------
_add(FrameSpec("DISPLAY_STATUS", FC_STATUS, (NodeId.DISPLAY,), "node", DISPLAY_STATUS_PERIOD_US, (
    Field("flags", 1, 8, False, 0, 15, "flags", flag_names=("ra_position_stale", "dec_position_stale",
                                                             "ra_axis_stale", "dec_axis_stale")),
    Field("frames_received", 2, 16, False, 0, 0xFFFF, "wrap", unit="frames", dbc_unit="frames",
          doc="POSITION and AXIS_STATUS frames consumed since reset"),
    Field("refreshes", 4, 16, False, 0, 0xFFFF, "wrap", unit="refreshes", dbc_unit="refreshes",
          doc="display refreshes since reset (4 per second)"),
), DisplayStatus, encode_display_status, decode_display_status, "display unit to host, every 1 s"))

_add(FrameSpec("DOME_STATUS", FC_STATUS, (NodeId.DOME,), "node", DOME_STATUS_PERIOD_US, (
    Field("mode", 1, 8, False, 0, 3, "enum", enum=DomeMode),
    Field("flags", 2, 8, False, 0, 15, "flags", flag_names=("moving", "on_target", "parked",
                                                             "position_stale")),
    Field("azimuth_cdeg", 3, 16, False, 0, AZIMUTH_CDEG_MAX, "wrap", unit="0.01 deg",
          dbc_name="azimuth", factor=0.01, dbc_unit="deg", doc="slit azimuth, N = 0, E = 90 deg"),
    Field("target_cdeg", 5, 16, False, 0, AZIMUTH_CDEG_MAX, "wrap", unit="0.01 deg",
          dbc_name="target_azimuth", factor=0.01, dbc_unit="deg", doc="azimuth the dome drives to"),
), DomeStatus, encode_dome_status, decode_dome_status, "dome controller to host, every 250 ms"))

_add(FrameSpec("DOME_COMMAND", FC_COMMAND, (NodeId.DOME,), "host", None, (
    Field("cmd", 1, 8, False, 0, 3, "enum", enum=DomeCommand),
    Field("value", 4, 32, True, I32_MIN, I32_MAX, "clamp", unit="0.01 deg", dbc_unit="cdeg",
          doc="GOTO: azimuth 0..35999 (others refused); other commands: 0"),
), DomeCommandFrame, encode_dome_command, decode_dome_command, "host to dome controller"))

_add(FrameSpec("WEATHER_STATUS", FC_STATUS, (NodeId.WEATHER,), "node", WEATHER_STATUS_PERIOD_US, (
    Field("flags", 1, 8, False, 0, 3, "flags", flag_names=("high_wind", "rain")),
    Field("temperature_cdegc", 2, 16, True, -32768, 32767, "clamp", unit="0.01 degC",
          dbc_name="temperature", factor=0.01, dbc_unit="degC", doc="air temperature"),
    Field("humidity_cpct", 4, 16, False, 0, HUMIDITY_CPCT_MAX, "clamp", unit="0.01 %",
          dbc_name="humidity", factor=0.01, dbc_unit="%", doc="relative humidity"),
    Field("wind_cm_s", 6, 16, False, 0, 0xFFFF, "clamp", unit="cm/s", dbc_name="wind_speed",
          factor=0.01, dbc_unit="m/s", doc="wind speed (1 s sample)"),
), WeatherStatus, encode_weather_status, decode_weather_status, "weather station to host, every 1 s"))
# -- end room nodes ----------------------------------------------------------------------------
# -- issue 12: tachometer and auxiliary-encoder frames (one block: codecs, table rows) ---------

#: Largest averaging window of the tachometer's speed, in 5 ms ticks (1 s; boards/tachometer.py).
TACH_MAX_WINDOW_TICKS: Final = 200


class AuxFlags(IntFlag):
    """``AUX_POSITION`` byte 1."""

    TURNS_UNKNOWN = 1   #: turn count not yet seeded from the main encoder: within-turn only


class TachStatus(NamedTuple):
    window_ticks: int       #: 5 ms ticks the speed is averaged over (1..200)
    counts: int             #: motor encoder count, low 16 bits of the QEI count (wraps)
    speed_urad_s: int       #: motor shaft speed, micro-rad/s (i32, saturating)


class AuxPosition(NamedTuple):
    flags: int              #: AuxFlags bits
    aux_counts: int         #: multi-turn encoder count: turns * 2**17 + 17-bit word (i32)


def tach_status_cob_id(node: _Int) -> int:
    """COB-ID of ``TACH_STATUS`` sent by tachometer ``node`` (6..9): 0x180 + node (its TPDO1)."""
    return FC_STATUS + _check_node("TACH_STATUS", node, TACH_NODES)


def aux_position_cob_id(node: _Int) -> int:
    """COB-ID of ``AUX_POSITION`` sent by auxiliary encoder ``node`` (0x0A, 0x0B): 0x180 + node."""
    return FC_STATUS + _check_node("AUX_POSITION", node, AUX_NODES)


_S_TACH_STATUS: Final = struct.Struct("<BBHi")
_DT_TACH: Final = DeviceType.TACHOMETER
_DT_AUX: Final = DeviceType.AUX_ENCODER


def encode_tach_status(window_ticks: _Int, counts: _Int, speed_urad_s: _Int) -> bytes:
    """Encode ``TACH_STATUS`` (0x180 + tachometer node): averaging window in 5 ms ticks
    (1..200, EncodeError otherwise), motor encoder count u16 (wraps), speed µrad/s i32
    (saturates)."""
    f = "TACH_STATUS"
    try:
        if not 1 <= window_ticks <= TACH_MAX_WINDOW_TICKS:
            raise EncodeError(f, "window_ticks", f"1..{TACH_MAX_WINDOW_TICKS}", window_ticks)
        return _S_TACH_STATUS.pack(_DT_TACH, window_ticks, counts & 0xFFFF,
                                   I32_MIN if speed_urad_s < I32_MIN
                                   else (I32_MAX if speed_urad_s > I32_MAX else speed_urad_s))
    except (struct.error, TypeError) as exc:
        raise _not_int(f, exc) from None


def decode_tach_status(data) -> TachStatus:
    """Decode ``TACH_STATUS``; raises MalformedFrame."""
    if len(data) != 8:                       # _unpack() inlined (every 5 ms per tachometer)
        raise MalformedFrame("TACH_STATUS", "dlc", "8 bytes", len(data))
    dt, window, counts, speed = _S_TACH_STATUS.unpack(data)
    if dt != _DT_TACH:
        raise _bad_type("TACH_STATUS", _DT_TACH, dt)
    if not 1 <= window <= TACH_MAX_WINDOW_TICKS:
        raise MalformedFrame("TACH_STATUS", "window_ticks", f"1..{TACH_MAX_WINDOW_TICKS}", window)
    return _tuple_new(TachStatus, (window, counts, speed))


_S_AUX_POSITION: Final = struct.Struct("<BB2xi")


def encode_aux_position(flags: _Int, aux_counts: _Int) -> bytes:
    """Encode ``AUX_POSITION`` (0x180 + auxiliary-encoder node): AuxFlags, multi-turn count i32
    (saturates)."""
    f = "AUX_POSITION"
    try:
        if flags & ~0x01 or flags < 0:       # _flags() and _clamp() inlined (every 10 ms)
            raise EncodeError(f, "flags", "flag bits within 0x01", flags)
        return _S_AUX_POSITION.pack(_DT_AUX, flags, I32_MIN if aux_counts < I32_MIN
                                    else (I32_MAX if aux_counts > I32_MAX else aux_counts))
    except (struct.error, TypeError) as exc:
        raise _not_int(f, exc) from None


def decode_aux_position(data) -> AuxPosition:
    """Decode ``AUX_POSITION``; raises MalformedFrame."""
    dt, flags, counts = _unpack(_S_AUX_POSITION, data, "AUX_POSITION", _DT_AUX)
    return _tuple_new(AuxPosition, (flags, counts))


_add(FrameSpec("TACH_STATUS", FC_STATUS, TACH_NODES, "node", TACH_STATUS_PERIOD_US, (
    Field("window_ticks", 1, 8, False, 1, TACH_MAX_WINDOW_TICKS, "id", unit="5 ms ticks",
          dbc_unit="ticks", doc="ticks the speed is averaged over (grows to 200 at low speed)"),
    Field("counts", 2, 16, False, 0, 0xFFFF, "wrap", unit="counts", dbc_unit="counts",
          doc="motor encoder (CP-850), low 16 bits of the QEI count"),
    Field("speed_urad_s", 4, 32, True, I32_MIN, I32_MAX, "clamp", unit="micro-rad/s",
          dbc_name="motor_speed", factor=1e-6, dbc_unit="rad/s",
          doc="motor shaft speed (0 with window 200: no count in 1 s)"),
), TachStatus, encode_tach_status, decode_tach_status,
    "motor tachometer to host, every 5 ms (paper 3.2 CP-850, 5.2 maintenance console)"))

_add(FrameSpec("AUX_POSITION", FC_STATUS, AUX_NODES, "node", AUX_POSITION_PERIOD_US, (
    Field("flags", 1, 8, False, 0, 1, "flags", flag_names=("turns_unknown",)),
    Field("aux_counts", 4, 32, True, I32_MIN, I32_MAX, "clamp", unit="counts", dbc_unit="counts",
          doc="multi-turn count turns * 2**17 + word; axis angle = counts * 360 deg / (2**17 * 10.8)"),
), AuxPosition, encode_aux_position, decode_aux_position,
    "auxiliary encoder to host, every 10 ms (paper 3.2 A25S through 1:10.8, 5.2 cross-check)"))

# -- issue 12: axis velocity readers ---------------------------------------------------------------

#: Largest averaging window of the axis velocity reader, in 10 ms ticks (1 s; boards/velocity_reader.py).
VEL_MAX_WINDOW_TICKS: Final = 100


class AxisVelocity(NamedTuple):
    window_ticks: int       #: 10 ms ticks the rate is averaged over (1..100)
    counts: int             #: friction-roller encoder count, low 16 bits of the QEI count (wraps)
    rate_marcsec_s: int     #: axis rate, milli-arcsec/s (i32, saturating)


def axis_velocity_cob_id(node: _Int) -> int:
    """COB-ID of ``AXIS_VELOCITY`` sent by velocity reader ``node`` (0x0F, 0x11): 0x180 + node (TPDO1)."""
    return FC_STATUS + _check_node("AXIS_VELOCITY", node, VEL_NODES)


_S_AXIS_VELOCITY: Final = struct.Struct("<BBHi")
_DT_VEL: Final = DeviceType.AXIS_VELOCITY


def encode_axis_velocity(window_ticks: _Int, counts: _Int, rate_marcsec_s: _Int) -> bytes:
    """Encode ``AXIS_VELOCITY`` (0x180 + velocity reader node): averaging window in 10 ms ticks
    (1..100, EncodeError otherwise), encoder count u16 (wraps), axis rate milli-arcsec/s i32
    (saturates)."""
    f = "AXIS_VELOCITY"
    try:
        if not 1 <= window_ticks <= VEL_MAX_WINDOW_TICKS:
            raise EncodeError(f, "window_ticks", f"1..{VEL_MAX_WINDOW_TICKS}", window_ticks)
        return _S_AXIS_VELOCITY.pack(_DT_VEL, window_ticks, counts & 0xFFFF,
                                     _clamp(rate_marcsec_s, I32_MIN, I32_MAX))
    except (struct.error, TypeError) as exc:
        raise _not_int(f, exc) from None


def decode_axis_velocity(data) -> AxisVelocity:
    """Decode ``AXIS_VELOCITY``; raises MalformedFrame."""
    dt, window, counts, rate = _unpack(_S_AXIS_VELOCITY, data, "AXIS_VELOCITY", _DT_VEL)
    if not 1 <= window <= VEL_MAX_WINDOW_TICKS:
        raise MalformedFrame("AXIS_VELOCITY", "window_ticks", f"1..{VEL_MAX_WINDOW_TICKS}", window)
    return _tuple_new(AxisVelocity, (window, counts, rate))


_add(FrameSpec("AXIS_VELOCITY", FC_STATUS, VEL_NODES, "node", AXIS_VELOCITY_PERIOD_US, (
    Field("window_ticks", 1, 8, False, 1, VEL_MAX_WINDOW_TICKS, "id", unit="10 ms ticks",
          dbc_unit="ticks", doc="ticks the rate is averaged over (grows to 100 at low speed)"),
    Field("counts", 2, 16, False, 0, 0xFFFF, "wrap", unit="counts", dbc_unit="counts",
          doc="friction-roller encoder (Gurley 8x60 through 1:24.5), low 16 bits of the QEI count"),
    Field("rate_marcsec_s", 4, 32, True, I32_MIN, I32_MAX, "clamp", unit="milli-arcsec/s",
          dbc_name="axis_rate", factor=0.001, dbc_unit="arcsec/s",
          doc="axis rate (window 100: the 1 s mean, fewer than 256 counts in 1 s)"),
), AxisVelocity, encode_axis_velocity, decode_axis_velocity,
    "axis velocity reader to host, every 10 ms (paper 2.2 friction-roller encoder, 3.4 lab network)"))

# -- end issue 12 tachometer/auxiliary-encoder block -----------------------------------------------

#: Per-command DBC signal for ``AXIS_COMMAND.value`` (the DBC multiplexes it by ``cmd``):
#: command -> (signal name, factor, unit).
AXIS_COMMAND_VALUE_SIGNALS: Final[dict[AxisCommand, tuple[str, float, str]]] = {
    c: (f"{c.name.lower()}_value", 1.0, "") for c in AxisCommand}
AXIS_COMMAND_VALUE_SIGNALS[AxisCommand.VELOCITY] = ("velocity", 0.001, "arcsec/s")
AXIS_COMMAND_VALUE_SIGNALS[AxisCommand.OPEN_LOOP] = ("open_loop_duty", 1 / Q15_FULL_SCALE, "duty")
AXIS_COMMAND_VALUE_SIGNALS[AxisCommand.SET_KP] = ("kp", 1e-6, "duty/(arcsec/s)")
AXIS_COMMAND_VALUE_SIGNALS[AxisCommand.SET_KI] = ("ki", 1e-6, "duty/(arcsec/s)")
#: Highest |VELOCITY| the axis firmware accepts, milli-arcsec/s: 3°/s, the paper's highest operated
#: rate (§4); the one source of ``boards.safety.SafetyLimits.max_rate_arcsec_s``'s default.
VELOCITY_MAX_MARCSEC_S: Final = 10_800_000
#: Raw range of ``AXIS_COMMAND.value`` the axis firmware accepts, per command (the DBC's ranges;
#: other commands: the whole i32). Out of range: the firmware refuses the command (EMCY
#: COMMAND_REFUSED, state unchanged). SET_KP/SET_KI are also refused outside the gain band
#: around the tuned gain (boards/safety.py), which no static range can express.
AXIS_COMMAND_VALUE_RANGES: Final[dict[AxisCommand, tuple[int, int]]] = {
    AxisCommand.VELOCITY: (-VELOCITY_MAX_MARCSEC_S, VELOCITY_MAX_MARCSEC_S),
    AxisCommand.OPEN_LOOP: (-Q15_FULL_SCALE, Q15_FULL_SCALE),
    AxisCommand.SET_KP: (0, I32_MAX),
    AxisCommand.SET_KI: (0, I32_MAX),
}


# ------------------------------------------------------------------------------------------------
# COB-ID table, names and the generic dispatcher
# ------------------------------------------------------------------------------------------------


def _message_name(spec: FrameSpec, node) -> str:
    if node is None or len(spec.nodes) == 1:
        return spec.name
    if spec.nodes in (AXIS_NODES, READER_NODES):   # RA / DEC is unambiguous here
        return f"{spec.name}_{'RA' if node in (NodeId.RA_AXIS, NodeId.RA_READER) else 'DEC'}"
    if spec.nodes in (TACH_NODES, AUX_NODES, VEL_NODES):   # TACH_STATUS_RA_1, AXIS_VELOCITY_DEC
        return f"{spec.name}_{NODE_NAME[node].split('_', 1)[1]}"
    return f"{spec.name}_{NODE_NAME[node]}"


#: cob_id -> (message name, FrameSpec, node or None). One entry per DBC message.
COB_TABLE: Final[dict[int, tuple[str, FrameSpec, int | None]]] = {}
for _spec in FRAMES.values():
    for _node in _spec.nodes:
        _cob = _spec.function_code + (0 if _node is None else int(_node))
        assert _cob not in COB_TABLE, hex(_cob)
        COB_TABLE[_cob] = (_message_name(_spec, _node), _spec, _node)
del _spec, _node, _cob

_DECODERS: Final = {cob: entry[1].decode for cob, entry in COB_TABLE.items()}
_NAMES: Final = {cob: entry[0] for cob, entry in COB_TABLE.items()}


def frame_name(cob_id: _Int) -> str:
    """Message name of ``cob_id`` as in the DBC, e.g. ``0x181 -> "AXIS_STATUS_RA"``;
    ``"UNKNOWN_0x123"`` for identifiers outside the protocol."""
    name = _NAMES.get(cob_id)
    return name if name is not None else f"UNKNOWN_0x{cob_id:03X}"


def frame_kind(cob_id: _Int) -> str | None:
    """Frame kind of ``cob_id`` (``"AXIS_STATUS"``...), or None if unknown."""
    entry = COB_TABLE.get(cob_id)
    return entry[1].name if entry else None


def node_of(cob_id: _Int) -> int | None:
    """Node the COB-ID is formed with (sender; addressee for commands), None for broadcasts."""
    entry = COB_TABLE.get(cob_id)
    return entry[2] if entry else None


def decode(cob_id: _Int, data) -> NamedTuple:
    """Decode any protocol frame by identifier.

    Raises
    ------
    MalformedFrame
        Unknown identifier (``field="cob_id"``), or the frame's decoder refuses it; for
        frames with a device-type byte, when it is not the sender's.
    """
    decoder = _DECODERS.get(cob_id)
    if decoder is None:
        raise MalformedFrame(frame_name(cob_id), "cob_id", "a schmidt protocol identifier",
                             hex(cob_id))
    return decoder(data)


def dbc_signals(cob_id: _Int, frame) -> dict:
    """Raw DBC signal values of a decoded frame (what cantools returns with ``scaling=False``).

    Flags fields expand into one signal per bit; the ``AXIS_COMMAND`` value goes to the signal
    its command selects. Used to check that the DBC and the struct codecs agree.
    """
    _, spec, node = COB_TABLE[cob_id]
    sig = {}
    if spec.device_type_byte:
        sig["device_type"] = int(DeviceType.HOST if spec.sender == "host" else DEVICE_TYPE_OF_NODE[node])  # type: ignore[index]
    for f in spec.fields:
        v = int(getattr(frame, f.name))
        if f.kind == "flags":
            for i, flag in enumerate(f.flag_names):
                sig[flag] = (v >> i) & 1
        elif spec.name == "AXIS_COMMAND" and f.name == "value":
            sig[AXIS_COMMAND_VALUE_SIGNALS[frame.cmd][0]] = v
        else:
            sig[f.dbc_name or f.name] = v
    return sig


def format_frame(cob_id: _Int, data) -> str:
    """One-line human-readable rendering for logs, never raising."""
    try:
        fields = decode(cob_id, data)
        body = ", ".join(f"{k}={getattr(v, 'name', v)}" for k, v in fields._asdict().items())
    except MalformedFrame as exc:
        body = f"MALFORMED ({exc}) {bytes(data).hex(' ')}"
    return f"{frame_name(cob_id)} 0x{cob_id:03X} [{body}]"


DBC_PATH: Final = Path(__file__).with_name("schmidt.dbc")


@lru_cache(maxsize=1)
def load_dbc():
    """Load ``bus/schmidt.dbc`` with cantools (imported lazily; cached).

    Returns
    -------
    cantools.database.can.Database
    """
    import cantools

    return cantools.database.load_file(str(DBC_PATH), strict=True)


# ------------------------------------------------------------------------------------------------
# DBC generation (``python -m bus.protocol > bus/schmidt.dbc``)
# ------------------------------------------------------------------------------------------------

_DBC_NODES: Final = ("HOST", "RA_AXIS", "DEC_AXIS", "RA_READER", "DEC_READER", "FOCUS",
              "TACH_RA_1", "TACH_RA_2", "TACH_DEC_1", "TACH_DEC_2", "AUX_RA", "AUX_DEC",
              "DISPLAY", "DOME", "WEATHER", "VEL_RA", "VEL_DEC")


def _fmt(x: float) -> str:
    return repr(int(x)) if float(x).is_integer() else repr(float(x))


def _receivers(spec: FrameSpec, node) -> str:
    if spec.name == "NMT":
        return ",".join(NODE_NAME[n] for n in BOARD_NODES)
    if spec.name == "STOP_ALL":
        return ",".join(NODE_NAME[n] for n in BOARD_NODES if DEVICE_TYPE_OF_NODE[n] in
                        (DeviceType.AXIS_CONTROLLER, DeviceType.FOCUS_CONTROLLER, DeviceType.DOME))
    if spec.sender == "host":
        return NODE_NAME[node]
    if spec.name == "LIMIT":
        return NODE_NAME[NodeId.RA_AXIS if node == NodeId.RA_READER else NodeId.DEC_AXIS]
    if spec.name == "POSITION":      # the host, and the axis's auxiliary encoder (turn count)
        return "HOST," + NODE_NAME[NodeId.AUX_RA if node == NodeId.RA_READER else NodeId.AUX_DEC]
    if spec.name == "HEARTBEAT" and node == NodeId.HOST:
        return ",".join(NODE_NAME[n] for n in BOARD_NODES)     # the host watchdog (0x1016)
    if spec.name == "POSITION":       # issue 12: the display and the dome consume it too
        return "HOST,DISPLAY,DOME"
    if spec.name == "AXIS_STATUS":    # issue 12: the display shows the axis mode
        return "HOST,DISPLAY"
    return "HOST"


def dbc_text() -> str:
    """Render the DBC describing :data:`FRAMES` (the content of ``bus/schmidt.dbc``)."""
    out = ['VERSION "schmidt-fil 1"', "", "NS_ :", "", "BS_:", "",
           "BU_: " + " ".join(_DBC_NODES), "", ""]
    comments, values, cycles = [], [], []
    for cob, (name, spec, node) in sorted(COB_TABLE.items()):
        tx = "HOST" if spec.sender == "host" or node is None else NODE_NAME[node]
        rx = _receivers(spec, node)
        out.append(f"BO_ {cob} {name}: {spec.dlc} {tx}")
        if spec.device_type_byte:
            dt = int(DeviceType.HOST if spec.sender == "host" else DEVICE_TYPE_OF_NODE[node])  # type: ignore[index]
            out.append(f' SG_ device_type : 0|8@1+ (1,0) [{dt}|{dt}] "" {rx}')
            values.append(f"VAL_ {cob} device_type " +
                          " ".join(f'{int(d)} "{d.name}"' for d in DeviceType) + " ;")
        comments.append(f'CM_ BO_ {cob} "{spec.doc}";')
        if spec.period_us:
            cycles.append(f'BA_ "GenMsgCycleTime" BO_ {cob} {spec.period_us // 1000};')
        for f in spec.fields:
            start = f.start_byte * 8
            sign = "-" if f.signed else "+"
            if f.kind == "flags":
                for i, flag in enumerate(f.flag_names):
                    out.append(f' SG_ {flag} : {start + i}|1@1+ (1,0) [0|1] "" {rx}')
                continue
            if spec.name == "AXIS_COMMAND" and f.name == "value":
                for cmd, (sig, factor, unit) in AXIS_COMMAND_VALUE_SIGNALS.items():
                    lo, hi = AXIS_COMMAND_VALUE_RANGES.get(cmd, (f.lo, f.hi))
                    out.append(f" SG_ {sig} m{int(cmd)} : {start}|{f.bits}@1{sign} "
                               f'({_fmt(factor)},0) [{_fmt(lo * factor)}|{_fmt(hi * factor)}]'
                               f' "{unit}" {rx}')
                continue
            mux = " M" if spec.name == "AXIS_COMMAND" and f.name == "cmd" else ""
            sig = f.dbc_name or f.name
            out.append(f" SG_ {sig}{mux} : {start}|{f.bits}@1{sign} ({_fmt(f.factor)},0) "
                       f'[{_fmt(f.lo * f.factor)}|{_fmt(f.hi * f.factor)}] "{f.dbc_unit}" {rx}')
            if f.enum is not None:
                values.append(f"VAL_ {cob} {sig} " +
                              " ".join(f'{int(m)} "{m.name}"' for m in f.enum) + " ;")
            if f.doc:
                comments.append(f'CM_ SG_ {cob} {sig} "{f.doc}";')
        out.append("")
    out += ["", *comments, "",
            'BA_DEF_ BO_ "GenMsgCycleTime" INT 0 65535;',
            'BA_DEF_DEF_ "GenMsgCycleTime" 0;', *cycles, "", *values, ""]
    return "\n".join(out)


def _range_text(f: Field) -> str:
    if f.kind == "flags":
        return ", ".join(f"bit{i} {n}" for i, n in enumerate(f.flag_names))
    if f.enum is not None and f.kind == "enum":
        return ", ".join(f"{int(m)} {m.name}" for m in f.enum if f.lo <= int(m) <= f.hi)  # type: ignore[attr-defined]
    return f"{f.lo}..{f.hi}"


def _type_text(f: Field) -> str:
    return f"{'i' if f.signed else 'u'}{f.bits}"


def frames_markdown() -> str:
    """The frame sections of docs/protocol.md (a test checks the page contains exactly this)."""
    out = []
    for spec in FRAMES.values():
        cobs = [cob for cob, (_, s, _) in sorted(COB_TABLE.items()) if s is spec]
        period = f"{spec.period_us // 1000} ms" if spec.period_us else "event"
        out += [f"### {spec.name} — {', '.join(f'0x{c:03X}' for c in cobs)} "
                f"(DLC {spec.dlc}, {period})", "", spec.doc + ".", "",
                "| bytes | field | type | range | kind | unit / meaning | DBC signal |",
                "|---|---|---|---|---|---|---|"]
        if spec.device_type_byte:
            dt = "0x10 HOST" if spec.sender == "host" else "the sender's DeviceType"
            out.append(f"| 0 | device_type | u8 | {dt} | fixed | | device_type |")
        for f in spec.fields:
            nbytes = (f.bits + 7) // 8
            b = str(f.start_byte) if nbytes == 1 else f"{f.start_byte}–{f.start_byte + nbytes - 1}"
            meaning = " ".join(x for x in (f.unit, f.doc) if x)
            if f.kind == "flags":
                sig = "one 1-bit signal per flag"
            elif spec.name == "AXIS_COMMAND" and f.name == "value":
                sig = "per cmd (multiplexed): " + ", ".join(
                    f"{n} ×{factor:g}{' ' + u if u else ''}"
                    + (f" [{AXIS_COMMAND_VALUE_RANGES[c][0]}..{AXIS_COMMAND_VALUE_RANGES[c][1]} raw]"
                       if c in AXIS_COMMAND_VALUE_RANGES else "")
                    for c, (n, factor, u) in AXIS_COMMAND_VALUE_SIGNALS.items())
            else:
                sig = (f.dbc_name or f.name) + (f" ×{f.factor:g}" if f.factor != 1 else "") + (
                    f" [{f.dbc_unit}]" if f.dbc_unit else "")
            out.append(f"| {b} | {f.name} | {_type_text(f)} | {_range_text(f)} | {f.kind} | "
                       f"{meaning} | {sig} |")
        out.append("")
    return "\n".join(out).rstrip("\n")


if __name__ == "__main__":  # pragma: no cover
    print(dbc_text(), end="")
