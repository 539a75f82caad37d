"""The one table of the CANopen object dictionaries (CiA 301) of every schmidt-fil board kind.

Everything CANopen about a board kind is written here once: identity, communication objects,
the PDO COB-ID plan, the EMCY codes and the manufacturer objects an operator tunes or aligns,
each with the value range the firmware accepts. The EDS files in this folder are *generated*
from this table (:mod:`bus.eds.generate`; a test checks the shipped files equal the generated
ones), and docs/canopen.md's COB-ID plan is checked against :func:`cob_id_plan_rows`.

Units: integers only (canopen's EDS reader ignores LowLimit/HighLimit of REAL32 objects, and the
firmware's command frames already use these integer units): gains in micro-duty per (″/s),
duties in Q15 (32767 = 100 %), rates in milli-arcsec/s, positions in encoder counts, times in ms.

Value ranges are today's firmware acceptance (boards/*.py, read 2026-11-21):

* Kp, Ki: AXIS_COMMAND SET_KP/SET_KI accept any value >= 0 of the i32 field
  (boards/axis_controller.py ``_command``), so 0 .. 2**31 − 1 micro-duty per (″/s).
* effort limit u_max: ``IncrementalPI`` requires 0 < u_max <= 1 → Q15 1 .. 32767.
* counter fraction p: ``AxisController`` requires 0 <= p < 1 → Q15 0 .. 32766.
* preset rates: VELOCITY accepts the i32 milli-″/s field; a preset is a magnitude (the command's
  direction byte gives the sign) → 0 .. 2**31 − 1.
* soft limits: ``PositionReader`` compares signed 29-bit axis angles (−180° .. +180°) and needs
  low < high → −2**28 .. 2**28 − 1 counts each, cross-checked on write (SDO abort 0x06090036).
* encoder offset: ``set_offset_counts`` stores the value modulo 2**29 → 0 .. 2**29 − 1.
* focus travel: FOCUS_STATUS carries pos_halfsteps as i16 → 0 .. 32767 half-steps.
* focus step rate: ``FocusController`` requires 0 < rate <= 1e6 → 1 .. 1 000 000 half-steps/s.
* LVDT reference: 10-bit ADC count → 0 .. 1023.
* watchdog (consumer heartbeat 0x1016): CiA 301 layout node id << 16 | time_ms.

Issue 11 (bounded firmware) narrows some of these bands; it changes them *here* and the
firmware reads them from here (one source).

Identity (0x1018): vendor id 0 (the project has no CiA-assigned vendor id; 0 claims none),
product code = the paper's device type byte (bus.protocol.DeviceType), revision =
major << 16 | minor of the project version, serial = product code << 16 | node id (the
emulated boards have no factory serial; written ``$NODEID+0x…`` in the EDS so a tool holding
the EDS predicts it; a real board answers its own serial).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, List, Optional, Tuple, Union

from bus import protocol as proto

__all__ = ["Entry", "Obj", "Kind", "KINDS", "VENDOR_ID", "REVISION", "SOFTWARE_VERSION",
           "EMCY_CODES", "EMCY_OF_FAULT", "EmcyCode", "serial_number", "cob_id_plan_rows",
           "UNSIGNED8", "UNSIGNED16", "UNSIGNED32", "INTEGER32", "VISIBLE_STRING",
           "NMT_CMD_CODE", "BOOTUP", "NMT_COB_ID", "sdo_rx_cob_id", "sdo_tx_cob_id",
           "emcy_cob_id", "heartbeat_cob_id", "heartbeat_node", "STOP_ALL_COB_ID", "PDO_FRAMES", "frame_fields",
           "cob_id_plan_markdown", "objects_markdown", "emcy_markdown"]

# CiA 301 data type codes (canopen.objectdictionary.datatypes uses the same numbers)
INTEGER8, INTEGER16, INTEGER32 = 0x02, 0x03, 0x04
INTEGER24, UNSIGNED24 = 0x10, 0x16
UNSIGNED8, UNSIGNED16, UNSIGNED32 = 0x05, 0x06, 0x07
VISIBLE_STRING = 0x09

VAR, ARRAY, RECORD = 0x7, 0x8, 0x9

#: The project has no CiA vendor id; 0 claims none (assumed).
VENDOR_ID = 0x00000000
#: Project version 0.1 → revision number major << 16 | minor (CiA 301 §7.5.2.26).
PROJECT_VERSION = (0, 1, 0)
REVISION = PROJECT_VERSION[0] << 16 | PROJECT_VERSION[1]
SOFTWARE_VERSION = "schmidt-fil %d.%d.%d" % PROJECT_VERSION
#: FileInfo dates of the EDS files (CiA 306 format): set them when this table changes.
EDS_DATE = "11-21-2026"
EDS_TIME = "12:00PM"

#: NMT command specifiers (CiA 301 §7.2.8.3.1) and the boot-up state byte.
NMT_CMD_CODE = {"start": 0x01, "stop": 0x02, "pre-operational": 0x80, "reset node": 0x81,
                "reset communication": 0x82}
BOOTUP = 0x00

#: CiA 301 pre-defined connection set (the ids every CANopen tool assumes).
NMT_COB_ID = 0x000


def sdo_rx_cob_id(node_id: int) -> int:
    """SDO client → server (request) COB-ID of ``node_id``: 0x600 + node."""
    return 0x600 + int(node_id)


def sdo_tx_cob_id(node_id: int) -> int:
    """SDO server → client (response) COB-ID of ``node_id``: 0x580 + node."""
    return 0x580 + int(node_id)


def emcy_cob_id(node_id: int) -> int:
    """EMCY COB-ID of ``node_id``: 0x080 + node."""
    return 0x080 + int(node_id)


def heartbeat_cob_id(node_id: int) -> int:
    """NMT error control (heartbeat, boot-up) COB-ID of ``node_id``: 0x700 + node."""
    return 0x700 + int(node_id)


def heartbeat_node(cob_id: int) -> int:
    """The node id of a heartbeat COB-ID (0 if ``cob_id`` is not in 0x701..0x77F)."""
    return cob_id - 0x700 if 0x701 <= cob_id <= 0x77F else 0


#: STOP_ALL replaces HOST_BROADCAST cmd 3: the host's TPDO1 (0x180 + host node 0x10 = 0x190),
#: consumed by every board with motion as its RPDO "STOP_ALL" (see docs/canopen.md).
STOP_ALL_COB_ID = 0x180 + int(proto.NodeId.HOST)

Value = Union[int, str, None]


@dataclass(frozen=True)
class Entry:
    """One object dictionary entry (a VAR, or a sub-index of an ARRAY/RECORD).

    ``default`` may be an ``int``, a ``str`` (strings, or ``"$NODEID+0x…"`` for node-relative
    values, CiA 306) or None (the value at power-on is set by the firmware's configuration;
    read it by SDO). ``low``/``high`` are the inclusive range the firmware accepts (None: the
    data type's range).
    """

    subindex: int
    name: str
    data_type: int
    access: str                       # "ro", "rw", "const", "wo"
    default: Value = None
    low: Optional[int] = None
    high: Optional[int] = None
    pdo_mapping: bool = False
    unit: str = ""
    description: str = ""


@dataclass(frozen=True)
class Obj:
    """One object: index, name, object type and its entries (a VAR has one, sub-index 0)."""

    index: int
    name: str
    object_type: int
    entries: Tuple[Entry, ...]
    description: str = ""

    def entry(self, subindex: int) -> Entry:
        for e in self.entries:
            if e.subindex == subindex:
                return e
        raise KeyError(f"0x{self.index:04X} has no sub-index {subindex}")


def var(index: int, name: str, data_type: int, access: str, default: Value = None,
        low: Optional[int] = None, high: Optional[int] = None, *, unit: str = "",
        description: str = "", pdo_mapping: bool = False) -> Obj:
    """A VAR object."""
    return Obj(index, name, VAR, (Entry(0, name, data_type, access, default, low, high,
                                        pdo_mapping, unit, description),), description)


def compound(index: int, name: str, object_type: int, subs: List[Entry],
             description: str = "", sub0_access: str = "ro") -> Obj:
    """An ARRAY or RECORD; sub-index 0 (highest sub-index supported) is added."""
    highest = max(e.subindex for e in subs)
    sub0 = Entry(0, "Highest sub-index supported", UNSIGNED8, sub0_access, highest)
    return Obj(index, name, object_type, (sub0,) + tuple(subs), description)


@dataclass(frozen=True)
class EmcyCode:
    """One EMCY error: CiA error code, error register bits, condition or event, project fault code."""

    name: str
    code: int                 # CiA 301 / CiA 402 error code (u16)
    register_bits: int        # 0x1001 bits besides bit 0 (generic), CiA 301 §7.5.2.2
    condition: bool           # True: active until cleared (then EMCY 0x0000); False: one-shot event
    fault_code: int           # the project's fault code (bus.protocol.FaultCode), 0 if new
    description: str


ERR_GENERIC, ERR_CURRENT, ERR_VOLTAGE, ERR_TEMPERATURE, ERR_COMMUNICATION = 0x01, 0x02, 0x04, 0x08, 0x10
ERR_PROFILE, ERR_MANUFACTURER = 0x20, 0x80

#: EMCY codes by name. Codes: CiA 301 Table 21 classes; the sub-codes 0x73xx, 0x86xx from CiA 402
#: (drive profile) where CiA 301 has only the class. Manufacturer bytes of every EMCY:
#: b3 project fault code, b4–5 detail u16, b6–7 occurrences of this code since reset (u16, saturating).
EMCY_CODES: Dict[str, EmcyCode] = {e.name: e for e in (
    EmcyCode("MALFORMED_FRAME", 0x8200, ERR_COMMUNICATION, False, 1,
             "a frame on an accepted id did not decode (detail = its COB-ID); counted"),
    EmcyCode("ENDAT_CRC", 0x7300, ERR_MANUFACTURER, True, 2,
             "EnDat position word failed its CRC (detail = reads since reset); clears on the next good read"),
    EmcyCode("OVER_CURRENT", 0x2300, ERR_CURRENT, True, 3,
             "a motor current above the threshold (detail = mA); clears when it falls below"),
    EmcyCode("LIMIT_STOP", 0x8612, ERR_PROFILE, True, 4,
             "axis stopped at a soft limit (detail = LIMIT flags); clears when the limit clears"),
    EmcyCode("COMMAND_REFUSED", 0x8613, ERR_PROFILE, False, 7,
             "a command outside its documented limits was refused, state unchanged (detail = reason << 8 | command)"),
    EmcyCode("BRAKE_CUT", 0x8614, ERR_PROFILE, False, 8,
             "the braking supervisor cut the duty: the axis did not slow down (detail = |rate| arcsec/s)"),
    EmcyCode("READER_LOST", 0x7380, ERR_MANUFACTURER, True, 9,
             "the axis's position reader is silent (detail 1) or reports invalid (2); motion refused"),
    EmcyCode("HOST_TIMEOUT", 0x8131, ERR_COMMUNICATION, True, 10,
             "host watchdog expired: controlled stop (detail = timeout ms)"),
    EmcyCode("OVERSPEED", 0x8400, ERR_PROFILE, True, 12,
             "axis faster than the overspeed limit: braking stop (detail = |rate| arcsec/s)"),
    EmcyCode("WATCHDOG_RESET", 0x6010, ERR_GENERIC, False, 5,
             "booted after a watchdog reset (detail = reset count)"),
    EmcyCode("STEP_LOSS", 0x8611, ERR_PROFILE, False, 6,
             "focus encoder and half-step counter disagree by a new amount (detail = missed half-steps)"),
    EmcyCode("HEARTBEAT_LOST", 0x8130, ERR_COMMUNICATION, True, 0,
             "a consumed heartbeat (0x1016) timed out (detail = the silent node id)"),
)}

#: The project's fault code -> EMCY name (what a firmware's ``send_fault(code)`` sends).
EMCY_OF_FAULT: Dict[int, str] = {e.fault_code: e.name for e in EMCY_CODES.values() if e.fault_code}


def serial_number(product_code: int, node_id: int) -> int:
    """Emulated serial number (0x1018 sub 4): product code << 16 | node id (assumed, see module doc)."""
    return (int(product_code) << 16) | int(node_id)


# ------------------------------------------------------------------------------------------------
# Board kinds
# ------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Pdo:
    """One PDO in the COB-ID plan.

    ``cob_id`` is an int or ``"$NODEID+0x…"`` (relative to the node that owns the object
    dictionary); ``frame`` names the paper's frame it carries (bus/protocol.py).
    """

    number: int               # 1..4
    frame: str
    cob_id: Union[int, str]
    period_ms: int = 0        # event timer (0 = event-driven only)
    transmission_type: int = 0xFE
    note: str = ""

    def cob_id_for(self, node_id: int) -> int:
        if isinstance(self.cob_id, int):
            return self.cob_id
        return int(self.cob_id.replace("$NODEID+", ""), 0) + node_id


@dataclass(frozen=True)
class Kind:
    """A board kind's CANopen description (one EDS file)."""

    name: str                 # file stem: axis_controller.eds
    product_name: str
    device_type: int          # byte 0 of its PDOs = product code
    nodes: Tuple[int, ...]
    hardware: str
    tpdos: Tuple[Pdo, ...]
    rpdos: Tuple[Pdo, ...]
    consumer_heartbeat: Tuple[Tuple[str, Value], ...]   # (name, default) per 0x1016 sub-index
    manufacturer: Tuple[Obj, ...]
    heartbeat_ms: int = proto.HEARTBEAT_PERIOD_US // 1000

    @property
    def product_code(self) -> int:
        return self.device_type

    def objects(self) -> List[Obj]:
        """All objects of the kind, sorted by index."""
        return sorted(_communication_objects(self) + list(self.manufacturer) + _diagnostics(self),
                      key=lambda o: o.index)

    def object(self, index: int) -> Obj:
        for o in self.objects():
            if o.index == index:
                return o
        raise KeyError(f"{self.name}: no object 0x{index:04X}")


def _ms(period_us: int) -> int:
    return int(period_us) // 1000


HOST_HB = f"0x{int(proto.NodeId.HOST) << 16:08X}"    # consumer heartbeat: host node, time 0 (off)
MAX_HB_CONSUMER = 0x007FFFFF                         # node id <= 127, time <= 65535 ms

I32_MAX = 2 ** 31 - 1
Q15 = 32767
POS_BITS = 29

_AXIS_MFR = (
    compound(0x2000, "PI controller", RECORD, [
        Entry(1, "Kp", INTEGER32, "rw", None, 0, I32_MAX, unit="micro-duty per arcsec/s",
              description="proportional gain x 1e6 (the SET_KP unit)"),
        Entry(2, "Ki", INTEGER32, "rw", None, 0, I32_MAX, unit="micro-duty per arcsec/s per tick",
              description="integral gain per 5 ms tick x 1e6 (the SET_KI unit)"),
        Entry(3, "Effort limit", UNSIGNED16, "rw", None, 1, Q15, unit="Q15 duty",
              description="u_max: |U| is clamped to it (32767 = 100 % duty)"),
        Entry(4, "Counter fraction", UNSIGNED16, "rw", None, 0, Q15 - 1, unit="Q15",
              description="p of the twin-motor drive law (paper 3.3: 0.10-0.25)"),
    ], "the incremental PI of paper 4 and the drive law of 3.3"),
    compound(0x2001, "Preset rates", ARRAY, [
        Entry(i + 1, f"{m} rate", INTEGER32, "rw", None, 0, proto.VELOCITY_MAX_MARCSEC_S,
              unit="milli-arcsec/s",
              description=f"magnitude of the {m} preset (AXIS_COMMAND cmd {i + 1}); takes effect at "
                          "the next preset command; at most the VELOCITY bound (3 deg/s)")
        for i, m in enumerate(("SLEW", "SET", "GUIDE", "FINE", "TRACK"))
    ], "axis rates of the preset commands; the command's direction byte gives the sign"),
)

#: Command log of the boards that take commands (issue 10: a command counter and acknowledgement
#: read back by SDO; the status PDOs have no spare byte for a sequence number).
_COMMAND_LOG = compound(0x2F01, "Command log", RECORD, [
    Entry(1, "Commands received", UNSIGNED16, "ro", None, unit="frames",
          description="command frames (RPDO1) decoded since reset, accepted or refused (wraps)"),
    Entry(2, "Last command", UNSIGNED8, "ro", None, description="cmd byte of the last one"),
    Entry(3, "Commands refused", UNSIGNED16, "ro", None, unit="frames",
          description="refused since reset (EMCY COMMAND_REFUSED sent; saturating)"),
    Entry(4, "Last refusal", UNSIGNED16, "ro", None,
          description="reason << 8 | command of the last refusal (its EMCY detail); 0 = none"),
], "what the host reads back to know a command arrived and whether it was refused")

_READER_MFR = (
    compound(0x2100, "Soft limits", RECORD, [
        Entry(1, "Low soft limit", INTEGER32, "rw", None, -(1 << (POS_BITS - 1)),
              (1 << (POS_BITS - 1)) - 1, unit="counts",
              description="axis angle (signed 29-bit, 2**29 per rev) where LIMIT low sets"),
        Entry(2, "High soft limit", INTEGER32, "rw", None, -(1 << (POS_BITS - 1)),
              (1 << (POS_BITS - 1)) - 1, unit="counts",
              description="axis angle where LIMIT high sets; must exceed the low limit"),
    ], "paper 3.3: soft limits on the telescope extremes"),
    var(0x2101, "Encoder offset", UNSIGNED32, "rw", None, 0, (1 << POS_BITS) - 1, unit="counts",
        description="alignment offset added to the raw EnDat word modulo 2**29 (paper 5.2)"),
    var(0x2102, "EnDat CRC errors", UNSIGNED32, "ro", None, unit="frames",
        description="EnDat frames rejected since reset"),
)

_FOCUS_MFR = (
    compound(0x2200, "Focus drive", RECORD, [
        Entry(1, "Travel", UNSIGNED16, "rw", None, 0, 32767, unit="half-steps",
              description="targets are clamped to +-travel (6.25 um per half-step)"),
        Entry(2, "Step rate", UNSIGNED32, "ro", None, 1, 1_000_000, unit="half-steps/s",
              description="half-step rate while moving"),
    ], "stepper drive of the focus housing (paper 3.2, 3.3)"),
    var(0x2201, "LVDT reference", UNSIGNED16, "rw", None, 0, 1023, unit="ADC counts",
        description="LVDT ADC count at the focus reference position (paper 3.3 re-referencing)"),
)

# -- issue 12, room nodes: manufacturer objects (values: plant/parameters.yaml, via host/network.py)
_DISPLAY_MFR = (
    compound(0x2300, "Display", RECORD, [
        Entry(1, "Refresh period", UNSIGNED16, "ro", None, 1, 65535, unit="ms",
              description="one display refresh (and display log line) per period"),
        Entry(2, "Stale timeout", UNSIGNED16, "ro", None, 1, 65535, unit="ms",
              description="an input older than this is shown as dashes"),
        Entry(3, "Frames received", UNSIGNED32, "ro", None, unit="frames",
              description="POSITION and AXIS_STATUS frames consumed since reset"),
    ], "digital display unit (paper 3.4)"),
)

_DOME_MFR = (
    compound(0x2400, "Dome drive", RECORD, [
        Entry(1, "Maximum rate", UNSIGNED32, "ro", None, 1, I32_MAX, unit="milli-deg/s",
              description="azimuth rate limit of the dome drive"),
        Entry(2, "Acceleration", UNSIGNED32, "ro", None, 1, I32_MAX, unit="milli-deg/s^2",
              description="azimuth acceleration limit"),
        Entry(3, "Deadband", UNSIGNED16, "rw", None, 1, 18000, unit="0.01 deg",
              description="the dome starts moving when the slit is off target by more"),
        Entry(4, "Park azimuth", UNSIGNED16, "rw", None, 0, 35999, unit="0.01 deg",
              description="azimuth PARK drives to"),
        Entry(5, "Site latitude", INTEGER32, "ro", None, -90_000_000, 90_000_000, unit="micro-deg",
              description="latitude used to turn HA/DEC into azimuth (paper 2: 29 deg 22 min N)"),
    ], "dome azimuth drive (paper 5.2)"),
)

_WEATHER_MFR = (
    compound(0x2500, "Weather limits", RECORD, [
        Entry(1, "High wind limit", UNSIGNED16, "ro", None, 1, 65535, unit="cm/s",
              description="HIGH_WIND sets at or above this wind speed"),
        Entry(2, "High wind clear", UNSIGNED16, "ro", None, 0, 65535, unit="cm/s",
              description="HIGH_WIND clears after the wind stayed below this for the clear hold"),
        Entry(3, "Clear hold", UNSIGNED16, "ro", None, 0, 65535, unit="s",
              description="how long a condition must be absent before its flag clears"),
        Entry(4, "Humidity limit", UNSIGNED16, "ro", None, 0, 10000, unit="0.01 %",
              description="RAIN also sets at or above this relative humidity (condensation)"),
    ], "weather station thresholds (paper 5.2)"),
)
# -- end room nodes
# -- issue 12: tachometer and auxiliary-encoder objects ---------------------------------------
_TACH_MFR = (
    var(0x2300, "Encoder counts per revolution", UNSIGNED32, "ro", None, 1, I32_MAX, unit="counts/rev",
        description="CP-850 counts per motor revolution (4 x lines; plant/parameters.yaml)"),
)

_AUX_MFR = (
    compound(0x2400, "Auxiliary encoder", RECORD, [
        Entry(1, "Turn count", INTEGER32, "ro", None, unit="encoder turns",
              description="turns of the encoder shaft since the axis zero (seeded from POSITION)"),
        Entry(2, "Turns seeded", UNSIGNED8, "ro", None, 0, 1,
              description="1 once the turn count was seeded from the main encoder's POSITION"),
        Entry(3, "Word bits", UNSIGNED8, "ro", None, 1, 31, unit="bits",
              description="single-turn word width (17: Gurley A25S, paper 3.2)"),
    ], "the A25S through the 1:10.8 reduction (paper 3.2); turn count: boards/aux_encoder.py"),
)
_VEL_MFR = (
    var(0x2300, "Encoder counts per revolution", UNSIGNED32, "ro", None, 1, I32_MAX, unit="counts/rev",
        description="friction-roller encoder counts per axis revolution (4.608e6 x 24.5, paper 2.2)"),
)
# -- end issue 12 objects ---------------------------------------------------------------------

KINDS: Dict[str, Kind] = {k.name: k for k in (
    Kind("axis_controller", "schmidt-fil axis controller", int(proto.DeviceType.AXIS_CONTROLLER),
         tuple(int(n) for n in proto.AXIS_NODES), "dsPIC30F3011",
         tpdos=(Pdo(1, "AXIS_STATUS", "$NODEID+0x180", _ms(proto.AXIS_STATUS_PERIOD_US)),
                Pdo(2, "AXIS_AUX", "$NODEID+0x280", _ms(proto.AXIS_AUX_PERIOD_US))),
         rpdos=(Pdo(1, "AXIS_COMMAND", "$NODEID+0x200"),
                Pdo(2, "LIMIT", "$NODEID+0x282", note="the axis's reader TPDO2 (node + 2)"),
                Pdo(3, "STOP_ALL", STOP_ALL_COB_ID, note="host TPDO1, consumed by every board")),
         consumer_heartbeat=(("Host heartbeat", HOST_HB), ("Position reader heartbeat", 0)),
         manufacturer=_AXIS_MFR + (_COMMAND_LOG,)),
    Kind("position_reader", "schmidt-fil EnDat position reader",
         int(proto.DeviceType.POSITION_READER), tuple(int(n) for n in proto.READER_NODES),
         "PIC18F4480",
         tpdos=(Pdo(1, "POSITION", "$NODEID+0x180", _ms(proto.POSITION_PERIOD_US)),
                Pdo(2, "LIMIT", "$NODEID+0x280", _ms(proto.LIMIT_REPEAT_US),
                    note="on change, then at the event timer while a flag is set")),
         rpdos=(), consumer_heartbeat=(("Host heartbeat", HOST_HB),), manufacturer=_READER_MFR),
    Kind("focus_controller", "schmidt-fil focus controller",
         int(proto.DeviceType.FOCUS_CONTROLLER), (int(proto.NodeId.FOCUS),), "PIC18F4431",
         tpdos=(Pdo(1, "FOCUS_STATUS", "$NODEID+0x180", _ms(proto.FOCUS_STATUS_PERIOD_US)),),
         rpdos=(Pdo(1, "FOCUS_COMMAND", "$NODEID+0x200"),
                Pdo(3, "STOP_ALL", STOP_ALL_COB_ID, note="host TPDO1, consumed by every board")),
         consumer_heartbeat=(("Host heartbeat", HOST_HB),), manufacturer=_FOCUS_MFR + (_COMMAND_LOG,)),
    # -- issue 12, room nodes
    Kind("display", "schmidt-fil digital display unit", int(proto.DeviceType.DISPLAY),
         (int(proto.NodeId.DISPLAY),), "PIC18F4480",
         tpdos=(Pdo(1, "DISPLAY_STATUS", "$NODEID+0x180", _ms(proto.DISPLAY_STATUS_PERIOD_US)),),
         rpdos=(Pdo(1, "POSITION", 0x180 + int(proto.NodeId.RA_READER), note="RA reader TPDO1"),
                Pdo(2, "POSITION", 0x180 + int(proto.NodeId.DEC_READER), note="DEC reader TPDO1"),
                Pdo(3, "AXIS_STATUS", 0x180 + int(proto.NodeId.RA_AXIS), note="RA axis TPDO1"),
                Pdo(4, "AXIS_STATUS", 0x180 + int(proto.NodeId.DEC_AXIS), note="DEC axis TPDO1")),
         consumer_heartbeat=(("Host heartbeat", HOST_HB),), manufacturer=_DISPLAY_MFR),
    Kind("dome", "schmidt-fil dome controller", int(proto.DeviceType.DOME),
         (int(proto.NodeId.DOME),), "PIC18F4431",
         tpdos=(Pdo(1, "DOME_STATUS", "$NODEID+0x180", _ms(proto.DOME_STATUS_PERIOD_US)),),
         rpdos=(Pdo(1, "DOME_COMMAND", "$NODEID+0x200"),
                Pdo(2, "POSITION", 0x180 + int(proto.NodeId.RA_READER), note="RA reader TPDO1"),
                Pdo(3, "STOP_ALL", STOP_ALL_COB_ID, note="host TPDO1, consumed by every board"),
                Pdo(4, "POSITION", 0x180 + int(proto.NodeId.DEC_READER), note="DEC reader TPDO1")),
         consumer_heartbeat=(("Host heartbeat", HOST_HB),), manufacturer=_DOME_MFR),
    Kind("weather", "schmidt-fil weather station", int(proto.DeviceType.WEATHER),
         (int(proto.NodeId.WEATHER),), "PIC18F4480",
         tpdos=(Pdo(1, "WEATHER_STATUS", "$NODEID+0x180", _ms(proto.WEATHER_STATUS_PERIOD_US)),),
         rpdos=(), consumer_heartbeat=(("Host heartbeat", HOST_HB),), manufacturer=_WEATHER_MFR),
    # -- end room nodes
    # -- issue 12: tachometer and auxiliary-encoder kinds --
    Kind("tachometer", "schmidt-fil motor tachometer", int(proto.DeviceType.TACHOMETER),
         tuple(int(n) for n in proto.TACH_NODES), "PIC18F4431",
         tpdos=(Pdo(1, "TACH_STATUS", "$NODEID+0x180", _ms(proto.TACH_STATUS_PERIOD_US)),),
         rpdos=(), consumer_heartbeat=(("Host heartbeat", HOST_HB),), manufacturer=_TACH_MFR),
    Kind("aux_encoder", "schmidt-fil auxiliary encoder", int(proto.DeviceType.AUX_ENCODER),
         tuple(int(n) for n in proto.AUX_NODES), "PIC18F4480",
         tpdos=(Pdo(1, "AUX_POSITION", "$NODEID+0x180", _ms(proto.AUX_POSITION_PERIOD_US)),),
         rpdos=(Pdo(1, "POSITION", "$NODEID+0x179", note="its axis reader TPDO1 (0x180 + node - 7): seeds the turn count"),),
         consumer_heartbeat=(("Host heartbeat", HOST_HB),), manufacturer=_AUX_MFR),
    Kind("velocity_reader", "schmidt-fil axis velocity reader", int(proto.DeviceType.AXIS_VELOCITY),
         tuple(int(n) for n in proto.VEL_NODES), "PIC18F4431",
         tpdos=(Pdo(1, "AXIS_VELOCITY", "$NODEID+0x180", _ms(proto.AXIS_VELOCITY_PERIOD_US)),),
         rpdos=(), consumer_heartbeat=(("Host heartbeat", HOST_HB),), manufacturer=_VEL_MFR),
    # -- end issue 12 kinds --
    Kind("host", "schmidt-fil host (USB-to-CAN gateway)", int(proto.DeviceType.HOST),
         (int(proto.NodeId.HOST),), "PIC18F4550",
         tpdos=(Pdo(1, "STOP_ALL", "$NODEID+0x180", note="broadcast; every board consumes it"),),
         rpdos=(), consumer_heartbeat=(), manufacturer=()),
)}


def _communication_objects(k: Kind) -> List[Obj]:
    objs = [
        var(0x1000, "Device type", UNSIGNED32, "ro", k.device_type << 16,
            description="bits 16-23: the paper's device type byte; bits 0-15: no CiA profile"),
        var(0x1001, "Error register", UNSIGNED8, "ro", 0, pdo_mapping=True,
            description="CiA 301 7.5.2.2; bit 0 set while any error is active"),
        compound(0x1003, "Pre-defined error field", ARRAY, [
            Entry(i, f"Standard error field {i}", UNSIGNED32, "ro", 0,
                  description="error code (bits 0-15) and the project fault code (bits 16-23); sub 1 newest")
            for i in range(1, 9)], "last 8 EMCYs; write 0 to sub 0 to clear", sub0_access="rw"),
        var(0x1008, "Manufacturer device name", VISIBLE_STRING, "const", k.product_name),
        var(0x1009, "Manufacturer hardware version", VISIBLE_STRING, "const", k.hardware),
        var(0x100A, "Manufacturer software version", VISIBLE_STRING, "const", SOFTWARE_VERSION),
        var(0x1014, "COB-ID EMCY", UNSIGNED32, "ro", "$NODEID+0x80"),
        var(0x1017, "Producer heartbeat time", UNSIGNED16, "rw", k.heartbeat_ms, 0, 65535,
            unit="ms", description="0 = no heartbeat"),
        compound(0x1018, "Identity object", RECORD, [
            Entry(1, "Vendor-ID", UNSIGNED32, "ro", VENDOR_ID),
            Entry(2, "Product code", UNSIGNED32, "ro", k.product_code),
            Entry(3, "Revision number", UNSIGNED32, "ro", REVISION),
            Entry(4, "Serial number", UNSIGNED32, "ro", f"$NODEID+0x{k.product_code << 16:X}"),
        ]),
        compound(0x1200, "SDO server parameter", RECORD, [
            Entry(1, "COB-ID client to server", UNSIGNED32, "ro", "$NODEID+0x600"),
            Entry(2, "COB-ID server to client", UNSIGNED32, "ro", "$NODEID+0x580"),
        ]),
    ]
    if k.consumer_heartbeat:
        objs.append(compound(0x1016, "Consumer heartbeat time", ARRAY, [
            Entry(i + 1, name, UNSIGNED32, "rw", default, 0, MAX_HB_CONSUMER,
                  description="node id << 16 | time ms; time 0 = not monitored")
            for i, (name, default) in enumerate(k.consumer_heartbeat)],
            "the watchdog times: a silent producer raises EMCY 0x8130"))
    for base, pdos, kind in ((0x1400, k.rpdos, "RPDO"), (0x1800, k.tpdos, "TPDO")):
        for p in pdos:
            subs = [Entry(1, "COB-ID used by " + kind, UNSIGNED32, "ro", p.cob_id,
                          description=p.frame + (f" ({p.note})" if p.note else "")),
                    Entry(2, "Transmission type", UNSIGNED8, "ro", p.transmission_type,
                          description="0xFE: event-driven, manufacturer-specific")]
            if kind == "TPDO":
                subs.append(Entry(5, "Event timer", UNSIGNED16, "ro", p.period_ms, unit="ms"))
            objs.append(compound(base + p.number - 1, f"{kind}{p.number} communication parameter",
                                 RECORD, subs, p.frame))
            objs.append(_mapping(p.frame, base + 0x200, p.number, kind))
    frames = [(p.frame, False) for p in k.tpdos] + [(p.frame, True) for p in k.rpdos]
    objs += [_process_data(f, rx) for f, rx in dict.fromkeys(frames)]
    return objs


#: Process-data objects: one RECORD per frame carried as a PDO, in this order from 0x3000.
PDO_FRAMES = ("AXIS_STATUS", "AXIS_AUX", "AXIS_COMMAND", "LIMIT", "POSITION", "FOCUS_STATUS",
              "FOCUS_COMMAND", "STOP_ALL",
              "TACH_STATUS", "AUX_POSITION",   # issue 12: tachometers, auxiliary encoders
              # issue 12, room nodes
              "DISPLAY_STATUS", "DOME_STATUS", "DOME_COMMAND", "WEATHER_STATUS",
              "AXIS_VELOCITY")                 # issue 12: axis velocity readers
PROCESS_DATA_BASE = 0x3000
_TYPE_BY_BYTES = {(1, False): UNSIGNED8, (2, False): UNSIGNED16, (3, False): UNSIGNED24,
                  (4, False): UNSIGNED32, (1, True): INTEGER8, (2, True): INTEGER16,
                  (3, True): INTEGER24, (4, True): INTEGER32}


def frame_fields(frame: str) -> List[Tuple[str, int, int, bool]]:
    """(name, start byte, bytes, signed) of every field of ``frame``'s 8 data bytes after byte 0.

    Taken from :data:`bus.protocol.FRAMES` (the one frame table); a field is mapped as the
    smallest whole-byte type holding its bits (the 29-bit pos_counts an UNSIGNED32, the 10-bit
    ADC counts an UNSIGNED16).
    """
    spec = proto.FRAMES[frame]
    return [(f.name, f.start_byte, (f.bits + 7) // 8, f.signed) for f in spec.fields]


def _layout(frame: str) -> List[Tuple[str, int, bool]]:
    """(name, bytes, signed) covering data bytes 0..7 in order: device type, fields, and one
    UNSIGNED8 ``reserved_bN`` per unused byte N (mapped like a field: some EDS tools do not
    handle CiA dummy entries, e.g. eds-utils 0.3.1 fails on them)."""
    out = [("device_type", 1, False)]
    pos = 1
    for name, start, nbytes, signed in frame_fields(frame):
        out += [(f"reserved_b{b}", 1, False) for b in range(pos, start)]
        out.append((name, nbytes, signed))
        pos = start + nbytes
    out += [(f"reserved_b{b}", 1, False) for b in range(pos, 8)]
    return out


def _process_data(frame: str, rx: bool) -> Obj:
    access = "rww" if rx else "ro"
    subs = [Entry(j + 1, name, _TYPE_BY_BYTES[(nbytes, signed)], access, pdo_mapping=True,
                  description="byte 0: the sender's device type" if j == 0 else "")
            for j, (name, nbytes, signed) in enumerate(_layout(frame))]
    return compound(PROCESS_DATA_BASE + PDO_FRAMES.index(frame), frame, RECORD, subs,
                    f"process data of {frame} (bus/protocol.py, bus/schmidt.dbc)")


def _mapping(frame: str, base: int, number: int, kind: str) -> Obj:
    """Static mapping (0x1600/0x1A00 + n − 1) of ``frame``: all 8 bytes, in order."""
    index = PROCESS_DATA_BASE + PDO_FRAMES.index(frame)
    entries = [(index << 16) | ((j + 1) << 8) | (8 * nbytes)
               for j, (name, nbytes, signed) in enumerate(_layout(frame))]
    subs = [Entry(i + 1, f"Mapped object {i + 1}", UNSIGNED32, "ro", e)
            for i, e in enumerate(entries)]
    return compound(base + number - 1, f"{kind}{number} mapping parameter", RECORD, subs, frame)


def _diagnostics(k: Kind) -> List[Obj]:
    if k.name == "host":
        return []
    return [compound(0x2F00, "Diagnostics", RECORD, [
        Entry(1, "Malformed frames", UNSIGNED16, "ro", None, unit="frames",
              description="frames on accepted ids that did not decode, since reset (saturating)"),
        Entry(2, "Reset count", UNSIGNED16, "ro", None, description="resets since power-on"),
        Entry(3, "Reset cause", UNSIGNED8, "ro", None,
              description="0 POWER_ON, 1 WATCHDOG, 2 SOFTWARE (bus.protocol.ResetCause)"),
        Entry(4, "Uptime", UNSIGNED32, "ro", None, unit="s", description="whole seconds since boot"),
    ], "what today's 8-byte HEARTBEAT carried besides the state")]


def _today_cob_id(frame: str, cob_id: int) -> int:
    """The identifier the frame had before issue 10 (HOST_BROADCAST 0x000, LIMIT 0x070 + reader),
    for the plan's table; bus/protocol.py now uses the PDO ids (:func:`protocol_cob_id` agrees)."""
    if frame == "STOP_ALL":
        return 0x000
    if frame == "LIMIT":
        return 0x070 + (cob_id - 0x280)          # the producing reader's node id
    return cob_id


def protocol_cob_id(frame: str, cob_id: int) -> int:
    """The identifier bus/protocol.py gives the frame carried by PDO ``cob_id`` (a test checks
    they are equal: the wiring follows the plan)."""
    if frame == "STOP_ALL":
        return proto.stop_all_cob_id()
    if frame == "LIMIT":
        return proto.limit_cob_id(cob_id - 0x280)
    return proto.FRAMES[frame].function_code + (cob_id & 0x7F)


def cob_id_plan_rows() -> List[Tuple[str, str, str, str, str]]:
    """The PDO part of the COB-ID plan: (frame, board kind, PDO, COB-IDs, today's COB-IDs)."""
    rows = []
    for direction in ("tpdos", "rpdos"):
        for k in KINDS.values():
            for p in getattr(k, direction):
                ids = [p.cob_id_for(n) for n in k.nodes]
                today = [_today_cob_id(p.frame, i) for i in ids]
                rows.append((p.frame, k.name, f"{direction[0].upper()}PDO{p.number}",
                             ", ".join(f"0x{i:03X}" for i in ids),
                             ", ".join(f"0x{i:03X}" for i in today)))
    return rows


def cob_id_plan_markdown() -> str:
    """docs/canopen.md's PDO table (a test checks the page contains exactly this)."""
    lines = ["| frame | board kind | PDO | COB-ID (per node) | before issue 10 |",
             "|---|---|---|---|---|"]
    for frame, kind, pdo, ids, today in cob_id_plan_rows():
        mark = "" if ids == today else " (moves)"
        lines.append(f"| {frame} | {kind} | {pdo} | {ids} | {today}{mark} |")
    return "\n".join(lines)


def emcy_markdown() -> str:
    """docs/canopen.md's table of EMCY codes (checked by a test)."""
    lines = ["| name | EMCY code | 0x1001 bits | kind | project fault code | meaning |",
             "|---|---|---|---|---|---|"]
    for e in EMCY_CODES.values():
        lines.append(f"| {e.name} | 0x{e.code:04X} | 0x{e.register_bits | ERR_GENERIC:02X} | "
                     f"{'condition' if e.condition else 'event'} | {e.fault_code} | {e.description} |")
    return "\n".join(lines)


def objects_markdown() -> str:
    """docs/canopen.md's table of manufacturer objects with ranges and units (checked by a test)."""
    lines = ["| board kind | index:sub | name | type | access | range | unit |",
             "|---|---|---|---|---|---|---|"]
    tnames = {INTEGER8: "INTEGER8", INTEGER16: "INTEGER16", INTEGER32: "INTEGER32",
              UNSIGNED8: "UNSIGNED8", UNSIGNED16: "UNSIGNED16", UNSIGNED32: "UNSIGNED32"}
    for k in KINDS.values():
        for o in k.objects():
            if not 0x2000 <= o.index < 0x3000:
                continue
            for e in o.entries:
                if e.subindex == 0 and o.object_type != VAR:
                    continue
                rng = "" if e.low is None else f"{e.low} .. {e.high}"
                name = e.name if o.object_type == VAR else f"{o.name}: {e.name}"
                lines.append(f"| {k.name} | 0x{o.index:04X}:{e.subindex} | {name} | "
                             f"{tnames.get(e.data_type, hex(e.data_type))} | {e.access} | {rng} | "
                             f"{e.unit} |")
    return "\n".join(lines)


def kind_spec(kind: str) -> "Kind":
    """The :class:`Kind` of board kind ``kind`` (a key of :data:`KINDS`).

    Raises
    ------
    KeyError
        For an unknown kind (the message lists the valid ones).
    """
    try:
        return KINDS[kind]
    except KeyError:
        raise KeyError(f"unknown board kind {kind!r}; valid: {sorted(KINDS)}") from None
