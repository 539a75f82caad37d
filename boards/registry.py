"""The board registry: the one table of which boards the telescope network has.

One :class:`BoardSpec` per board kind: its firmware class, device type, the plant ports its
firmware needs, and its instances (scenario name, node id, axis). Everything else that lists
boards is derived from this table: the scenario schema's board names, the host's health check
and node names, the report's board rows, :func:`host.network.build_network`, the frames each
board sends and accepts (from :data:`bus.protocol.COB_TABLE` by node) and the RS232 telemetry
ports.

The wire-level facts stay in the protocol layer below (``bus`` never imports ``boards``): the
node id enum, the device type byte of each node and the frame layouts (``bus/protocol.py`` and
``bus/schmidt.dbc``). A test checks that this table and the protocol agree.

Adding a board kind = one firmware file + one entry in :data:`REGISTRY` (+ its node id and
frames in ``bus/protocol.py`` and the DBC; + a port factory in ``host/network.py`` if it needs a
plant port no other board has). See docs/architecture.md.
"""

from __future__ import annotations

from dataclasses import dataclass

from boards.aux_encoder import AuxEncoder
from boards.axis_controller import AxisController
from boards.display import DisplayUnit
from boards.dome import DomeController
from boards.firmware_base import Firmware
from boards.focus_controller import FocusController
from boards.position_reader import PositionReader
from boards.tachometer import Tachometer
from boards.velocity_reader import AxisVelocityReader
from boards.usb_gateway import UsbGateway
from boards.weather import WeatherStation
from bus import protocol as P
from bus.eds.objects import KINDS as EDS_KINDS

__all__ = ["BoardInstance", "BoardSpec", "REGISTRY", "BOARDS", "BOARD_NAMES", "NODE_NAMES",
           "DEFAULT_BOARD_NAMES", "CANOPEN_KINDS", "GATEWAY_KIND",
           "board", "board_of_node", "nodes_of_kind", "NETWORK_KINDS", "NETWORKS", "NETWORK_NAMES",
           "network_boards", "network_nodes", "canopen_nodes"]


@dataclass(frozen=True)
class BoardInstance:
    """One board on the bus.

    Attributes
    ----------
    name : str
        Scenario name (``faults[].board``), log and report name, scheduler owner.
    node_id : int
        CAN node id (``bus.protocol.NodeId``).
    axis : str or None
        ``"ra"``/``"dec"`` for per-axis boards (selects the plant an axis board's ports reach).
    motor : str or None
        ``"a"``/``"b"`` for per-motor boards (the tachometers): which motor of the axis.
    """

    name: str
    node_id: int
    axis: str | None = None
    motor: str | None = None


@dataclass(frozen=True)
class BoardSpec:
    """One board kind.

    Attributes
    ----------
    kind : str
        Registry key (``"axis_controller"``).
    firmware : type
        The firmware class (a :class:`boards.firmware_base.Firmware`: a CANopen
        :class:`boards.firmware_base.Board`, or the USB gateway); constructed as
        ``firmware(scheduler, bus, node_id, name=..., serial_port=..., **ports, **settings)``.
    device_type : bus.protocol.DeviceType
        Byte 0 of every frame it sends (must match ``bus.protocol.DEVICE_TYPE_OF_NODE``).
    ports : tuple of str
        Keyword arguments of ``firmware`` that are plant ports; ``host/network.py`` builds each
        from its port table (``PORTS``) for the instance's axis.
    instances : tuple of BoardInstance
        The boards of this kind, in node order.
    description : str
        The board (paper section).
    """

    kind: str
    firmware: type
    device_type: P.DeviceType
    ports: tuple[str, ...]
    instances: tuple[BoardInstance, ...]
    description: str = ""

    @property
    def canopen(self) -> bool:
        """True for a board with a CANopen device (an EDS, ``firmware.CANOPEN_KIND``); False for
        the USB gateway, the host's node, whose CANopen roles are the PC's (docs/usb-gateway.md)."""
        return bool(self.firmware.CANOPEN_KIND)

    def sends(self, node_id: int) -> list[tuple[int, str]]:
        """``(cob_id, frame name)`` of every frame the board with ``node_id`` sends: its
        protocol frames (TPDOs, EMCY, heartbeat) and its SDO responses. The USB gateway sends
        nothing of its own: the frames of the host's node (every frame whose sender is the
        host, and the host's heartbeat) that the PC gives it."""
        if not self.canopen:
            return [(cob, name) for cob, (name, spec, n) in sorted(P.COB_TABLE.items())
                    if spec.sender == "host" or n == node_id]
        return [(cob, name) for cob, (name, spec, n) in sorted(P.COB_TABLE.items())
                if n == node_id and spec.sender != "host"]

    def accepts(self, node_id: int) -> list[tuple[int, str]]:
        """``(cob_id, frame name)`` of every frame the board with ``node_id`` acts on, from its
        EDS (``bus/eds``): NMT, the consumed heartbeats (0x1016 defaults: the host's), its
        RPDOs (STOP_ALL, LIMIT, then its own command frame, last) and SDO requests (before the
        command), from the EDS of ``firmware.CANOPEN_KIND``. The board's firmware builds the
        same set from its ``CanopenDevice``. The USB gateway passes every frame the boards send
        to the PC (its power-on acceptance filters pass all)."""
        if not self.canopen:
            return [(cob, name) for cob, (name, spec, n) in sorted(P.COB_TABLE.items())
                    if spec.sender != "host" and n != node_id]
        eds = EDS_KINDS[self.firmware.CANOPEN_KIND]
        out = [(P.nmt_cob_id(), P.frame_name(P.nmt_cob_id()))]
        out += [(P.heartbeat_cob_id(P.NodeId.HOST), P.frame_name(P.heartbeat_cob_id(P.NodeId.HOST)))]
        rpdos = sorted(p.cob_id_for(node_id) for p in eds.rpdos)
        own = [c for c in rpdos if P.node_of(c) == node_id]
        out += [(c, P.frame_name(c)) for c in rpdos if c not in own]
        out += [(P.sdo_request_cob_id(node_id), P.frame_name(P.sdo_request_cob_id(node_id)))]
        out += [(c, P.frame_name(c)) for c in own]
        return out


#: The board kinds of the ARIES Schmidt network (paper §3.3–§3.4; node ids docs/protocol.md).
REGISTRY: tuple[BoardSpec, ...] = (
    BoardSpec(
        kind="axis_controller", firmware=AxisController, device_type=P.DeviceType.AXIS_CONTROLLER,
        ports=("read_qei_counts", "on_duties", "shunt_a_v", "shunt_b_v"),
        instances=(BoardInstance("ra-axis", P.NodeId.RA_AXIS, "ra"),
                   BoardInstance("dec-axis", P.NodeId.DEC_AXIS, "dec")),
        description="axis controller, dsPIC30F3011: QEI, 2 PWM, shunt ADC, PI at 5 ms (§3.3)"),
    BoardSpec(
        kind="position_reader", firmware=PositionReader, device_type=P.DeviceType.POSITION_READER,
        ports=("read_position_word",),
        instances=(BoardInstance("ra-reader", P.NodeId.RA_READER, "ra"),
                   BoardInstance("dec-reader", P.NodeId.DEC_READER, "dec")),
        description="EnDat absolute position reader, PIC18F4480 (§3.2, §3.4)"),
    BoardSpec(
        kind="focus_controller", firmware=FocusController, device_type=P.DeviceType.FOCUS_CONTROLLER,
        ports=("on_step", "read_lvdt_v", "read_index", "on_power", "read_encoder_counts"),
        instances=(BoardInstance("focus", P.NodeId.FOCUS, None),),
        description="focus controller, PIC18F4431: stepper, LVDT, motor encoder (§3.3)"),
    # -- issue 12, room nodes ---------------------------------------------------------------
    BoardSpec(
        kind="display", firmware=DisplayUnit, device_type=P.DeviceType.DISPLAY,
        ports=("on_show",),
        instances=(BoardInstance("display", P.NodeId.DISPLAY, None),),
        description="digital display unit: HA/DEC and rates from POSITION and AXIS_STATUS (§3.4)"),
    BoardSpec(
        kind="dome", firmware=DomeController, device_type=P.DeviceType.DOME,
        ports=("read_azimuth_counts", "set_speed_reference"),
        instances=(BoardInstance("dome", P.NodeId.DOME, None),),
        description="dome controller: slit azimuth follows the telescope (§5.2)"),
    BoardSpec(
        kind="weather", firmware=WeatherStation, device_type=P.DeviceType.WEATHER,
        ports=("read_temperature_v", "read_humidity_v", "read_wind_v", "read_rain"),
        instances=(BoardInstance("weather", P.NodeId.WEATHER, None),),
        description="weather station: temperature, humidity, wind, rain; high-wind and rain flags (§5.2)"),
    # -- end room nodes
    # -- issue 12: motor tachometers and auxiliary encoders --
    BoardSpec(
        kind="tachometer", firmware=Tachometer, device_type=P.DeviceType.TACHOMETER,
        ports=("read_motor_counts",),
        instances=(BoardInstance("ra-tach-1", P.NodeId.TACH_RA_1, "ra", "a"),
                   BoardInstance("ra-tach-2", P.NodeId.TACH_RA_2, "ra", "b"),
                   BoardInstance("dec-tach-1", P.NodeId.TACH_DEC_1, "dec", "a"),
                   BoardInstance("dec-tach-2", P.NodeId.TACH_DEC_2, "dec", "b")),
        description="motor tachometer, CP-850 on each motor shaft, QEI (§3.2, §3.4, §5.2)"),
    BoardSpec(
        kind="aux_encoder", firmware=AuxEncoder, device_type=P.DeviceType.AUX_ENCODER,
        ports=("read_aux_word",),
        instances=(BoardInstance("ra-aux", P.NodeId.AUX_RA, "ra"),
                   BoardInstance("dec-aux", P.NodeId.AUX_DEC, "dec")),
        description="auxiliary encoder, 17-bit A25S through 1:10.8, SSI (§3.2, §5.2)"),
    BoardSpec(
        kind="velocity_reader", firmware=AxisVelocityReader, device_type=P.DeviceType.AXIS_VELOCITY,
        ports=("read_qei_counts",),
        instances=(BoardInstance("ra-velocity", P.NodeId.VEL_RA, "ra"),
                   BoardInstance("dec-velocity", P.NodeId.VEL_DEC, "dec")),
        description="axis velocity reader, friction-roller encoder 1:24.5, QEI (§2.2, §3.4; assumed own node)"),
    # -- end issue 12 --
    BoardSpec(
        kind="usb_gateway", firmware=UsbGateway, device_type=P.DeviceType.HOST, ports=(),
        instances=(BoardInstance("gateway", P.NodeId.HOST, None),),
        description="USB-HID CAN gateway, PIC18F4550: the host PC's node (§3.4; docs/usb-gateway.md)"),
)

#: Every board by scenario name, in node order: name -> (spec, instance).
BOARDS: dict[str, tuple[BoardSpec, BoardInstance]] = dict(sorted(
    ((i.name, (s, i)) for s in REGISTRY for i in s.instances), key=lambda kv: int(kv[1][1].node_id)))
#: Scenario board names in node order.
BOARD_NAMES: tuple[str, ...] = tuple(BOARDS)
#: Board name of each node id.
NODE_NAMES: dict[int, str] = {int(i.node_id): name for name, (_, i) in BOARDS.items()}
#: Kind of the USB-HID gateway: the host's node, through which the host client talks.
GATEWAY_KIND = "usb_gateway"
#: Kinds of the boards with a CANopen device (every kind but the gateway): the host's health
#: check, identity reads and heartbeat watch cover these.
CANOPEN_KINDS: tuple[str, ...] = tuple(s.kind for s in REGISTRY if s.canopen)


def board(name: str) -> tuple[BoardSpec, BoardInstance]:
    """The spec and instance of board ``name``.

    Raises
    ------
    KeyError
        Unknown name (the message lists the valid names).
    """
    try:
        return BOARDS[name]
    except KeyError:
        raise KeyError(f"unknown board {name!r}; valid: {', '.join(BOARD_NAMES)}") from None


def board_of_node(node_id: int) -> str:
    """Board name of ``node_id`` (``"node-<n>"`` for a node that is not a board)."""
    return NODE_NAMES.get(int(node_id), f"node-{node_id}")


def nodes_of_kind(kind: str) -> dict[str, int]:
    """``{axis or name: node id}`` of the boards of ``kind`` (``{"ra": 1, "dec": 2}``)."""
    spec = next(s for s in REGISTRY if s.kind == kind)
    return {(i.axis or i.name): int(i.node_id) for i in spec.instances}


# -- networks by name (issue 12) ------------------------------------------------------------------
#: Board kinds of each named network; a network is every registered instance of its kinds, in node
#: order (so a kind registered on another branch joins the networks naming it once it is merged;
#: ``full`` is every board of the registry).
#:
#: * ``basic``: today's five boards (2 axis controllers, 2 EnDat readers, focus) + the USB-HID
#:   gateway (kind ``usb_gateway``, instance ``gateway``) when it is registered;
#: * ``lab``: the paper's ten nodes tested in the lab (§3.4: "position and velocity measurements
#:   for the two axes, velocity measurements for the four DC motors, digital display unit, along
#:   with USB-to-CAN node"): 2 axis controllers, 2 readers, 4 tachometers, the display, the gateway;
#: * ``full``: every board of the registry: 17, Fig. 5's "over sixteen" (the axis velocity
#:   readers' reason: docs/boards.md).
#: Kind of the host's own node (the PC's USB-HID gateway, paper §3.4): on every network, an
#: explicit list included.
HOST_NODE_KIND = GATEWAY_KIND
NETWORK_KINDS: dict[str, tuple[str, ...] | None] = {
    "basic": ("axis_controller", "position_reader", "focus_controller", "usb_gateway"),
    "lab": ("axis_controller", "position_reader", "tachometer", "display", "usb_gateway"),
    "full": None,
}


def _network(kinds: tuple[str, ...] | None) -> tuple[str, ...]:
    return tuple(name for name, (s, _) in BOARDS.items() if kinds is None or s.kind in kinds)


#: Network name -> board instance names, in node order.
NETWORKS: dict[str, tuple[str, ...]] = {name: _network(kinds) for name, kinds in NETWORK_KINDS.items()}
#: Valid network names for a scenario's ``network:`` key.
NETWORK_NAMES: tuple[str, ...] = tuple(NETWORKS)
#: Boards built when nothing names them: the ``basic`` network (a scenario's default).
DEFAULT_BOARD_NAMES: tuple[str, ...] = NETWORKS["basic"]


def network_boards(network: str | list | tuple) -> tuple[str, ...]:
    """Board names of ``network`` in node order: a name of :data:`NETWORKS` or a list of board
    instance names (each once; the host's node, kind :data:`HOST_NODE_KIND`, is added when
    registered: the PC is always on the bus).

    Raises
    ------
    KeyError
        Unknown network name or board name (the message lists the valid ones).
    ValueError
        A board named twice.
    """
    if isinstance(network, str):
        try:
            return NETWORKS[network]
        except KeyError:
            raise KeyError(f"unknown network {network!r}; valid: {', '.join(NETWORK_NAMES)} "
                           f"or a list of board names") from None
    names = list(network)
    for n in names:
        board(n)
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError(f"board named more than once: {', '.join(dup)}")
    # the host's own node (the USB-HID gateway, once registered) is on every network
    host = {n for n, (s, _) in BOARDS.items() if s.kind == HOST_NODE_KIND}
    return tuple(n for n in BOARD_NAMES if n in names or n in host)


def network_nodes(network: str | list | tuple) -> tuple[int, ...]:
    """Node ids of the CANopen boards of ``network`` (those that answer the host's SDO health
    check and send heartbeats), in node order; the host's own node (the gateway) is not one.

    Raises
    ------
    KeyError, ValueError
        As :func:`network_boards`.
    """
    return canopen_nodes(network_boards(network))


def canopen_nodes(names, table=None) -> tuple[int, ...]:
    """Node ids of the CANopen boards among board ``names`` (in their order), the host's own node
    excepted: the one rule for "which boards answer the health check and send heartbeats".

    Parameters
    ----------
    names : iterable of str
        Board instance names.
    table : dict, optional
        ``name -> (BoardSpec, BoardInstance)``; default :data:`BOARDS` (the assembly passes the
        table it builds from, which a test may extend with a new board kind).
    """
    table = BOARDS if table is None else table
    return tuple(int(table[n][1].node_id) for n in names
                 if table[n][0].canopen and table[n][1].node_id != P.NodeId.HOST)


assert all(issubclass(s.firmware, Firmware) for s in REGISTRY)
