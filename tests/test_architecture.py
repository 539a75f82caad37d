"""The structure docs/architecture.md promises: import direction, one registry, one source per constant."""

import ast
import re
from pathlib import Path

import can

from boards import registry as R
from bus import protocol as P
from bus import telemetry as T
from bus.eds.objects import KINDS
from host.faults import FAULT_KINDS, FAULTS
from host.network import PORTS, build_network
from host.scenario import Fault, parse_scenario

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("boards", "bus", "plant", "host")


def _imports(path: Path) -> set[str]:
    """Every module imported anywhere in ``path`` (function-local imports included)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.add(node.module)
            out |= {f"{node.module}.{a.name}" for a in node.names}
    return out


def _package_imports() -> dict[str, set[str]]:
    deps = {}
    for pkg in PACKAGES:
        for f in (ROOT / pkg).rglob("*.py"):
            deps[str(f.relative_to(ROOT))] = {m for m in _imports(f) if m.split(".")[0] in PACKAGES}
    return deps


def test_imports_run_one_way_between_the_four_packages():
    """host -> boards/bus/plant; boards -> bus; plant -> only the three leaf modules bus.units,
    bus.errors and bus.jit_entry; bus -> nothing of the others. So no import cycle among the packages."""
    allowed = {"host": set(PACKAGES), "boards": {"boards", "bus"}, "bus": {"bus"}, "plant": {"plant", "bus"}}
    for f, mods in _package_imports().items():
        pkg = f.split("/")[0]
        for m in mods:
            assert m.split(".")[0] in allowed[pkg], f"{f} imports {m}"
            if pkg == "plant" and m.startswith("bus"):
                assert m in ("bus.units", "bus.errors", "bus.units.ARCSEC_PER_RAD", "bus.units.ARCSEC_PER_REV",
                             "bus.units.check_counter_fraction", "bus.errors.ConfigurationError",
                             "bus.jit_entry", "bus.jit_entry.entry_point"), f"{f} imports {m}"


def test_host_modules_have_no_import_cycle():
    """Within host/, module imports form no cycle (scenario no longer imports network back)."""
    graph = {}
    for f, mods in _package_imports().items():
        if f.startswith("host/"):
            me = f[:-3].replace("/", ".")
            graph[me] = {m for m in mods if m.startswith("host.") and m.count(".") == 1}

    def visit(node, stack):
        assert node not in stack, " -> ".join([*stack, node])
        for nxt in graph.get(node, ()):
            visit(nxt, [*stack, node])

    for node in graph:
        visit(node, [])


def test_shared_constants_are_defined_once():
    """ARCSEC_PER_RAD, ARCSEC_PER_REV and Q15_FULL_SCALE are assigned only in bus/units.py, and no
    module writes their values out as literals."""
    for pkg in PACKAGES:
        for f in (ROOT / pkg).rglob("*.py"):
            rel = str(f.relative_to(ROOT))
            text = f.read_text(encoding="utf-8")
            for node in ast.walk(ast.parse(text)):
                if isinstance(node, ast.Assign) and rel != "bus/units.py":
                    names = {t.id for t in node.targets if isinstance(t, ast.Name)}
                    assert not names & {"ARCSEC_PER_RAD", "ARCSEC_PER_REV", "Q15_FULL_SCALE"}, rel
            if rel != "bus/units.py" and not rel.startswith("plant/calibration"):
                code = re.sub(r"#.*", "", text)
                assert "648_000" not in code and "1_296_000" not in code and "206264" not in code, rel


def test_registry_agrees_with_the_protocol():
    """Every board's node id and device type are the protocol's; the registry names every node
    once (the CANopen boards and, as the host's node 0x10, the USB gateway); telemetry device ids
    come from the same table."""
    assert sorted(int(i.node_id) for _, i in R.BOARDS.values()) == sorted(int(n) for n in P.ALL_NODES)
    assert sorted(int(i.node_id) for s, i in R.BOARDS.values() if s.canopen) == sorted(int(n) for n in P.BOARD_NODES)
    for name, (spec, inst) in R.BOARDS.items():
        assert P.DEVICE_TYPE_OF_NODE[inst.node_id] == spec.device_type, name
        if not spec.canopen:      # the gateway: the host's frames out, every board's frame in
            assert spec.kind == R.GATEWAY_KIND and inst.node_id == P.NodeId.HOST and not spec.ports, name
            assert int(inst.node_id) not in T.DEVICE_OF_NODE, name         # no RS232 telemetry
            sends = {cob for cob, _ in spec.sends(inst.node_id)}
            assert {P.nmt_cob_id(), P.stop_all_cob_id(), P.heartbeat_cob_id(P.NodeId.HOST)} <= sends
            assert {P.sdo_request_cob_id(n) for n in P.BOARD_NODES} <= sends
            boards_send = {cob for s, i in R.BOARDS.values() if s.canopen for cob, _ in s.sends(i.node_id)}
            assert {cob for cob, _ in spec.accepts(inst.node_id)} == boards_send
            continue
        assert T.DEVICE_OF_NODE[int(inst.node_id)] == int(spec.device_type), name
        assert set(spec.ports) <= set(PORTS), f"{name}: no port factory for {set(spec.ports) - set(PORTS)}"
        assert spec.sends(inst.node_id), name
        accepts = [cob for cob, _ in spec.accepts(inst.node_id)]
        assert accepts[0] == P.nmt_cob_id() and P.sdo_request_cob_id(inst.node_id) in accepts
        assert spec.firmware.CANOPEN_KIND in KINDS, name


def test_scenario_names_come_from_the_registry_and_the_fault_table():
    """The scenario schema's board and fault names are the registry's and the fault table's."""
    ann = Fault.model_fields
    board_names, none = ann["board"].annotation.__args__       # Literal[BOARD_NAMES] | None
    assert board_names.__args__ == R.BOARD_NAMES and none is type(None)
    assert ann["kind"].annotation.__args__ == FAULT_KINDS == tuple(FAULTS)


def test_built_network_follows_the_registry(tmp_path):
    """build_network on the ``full`` network builds exactly the registry's boards, each of its
    firmware class, and on the bus each board sends only the frames the registry says it sends."""
    sc = parse_scenario("name: r\nnetwork: full\nsegments:\n  - {name: a, mode: stop, duration_s: 1}\n",
                        str(tmp_path / "s.yaml"))
    tel = build_network(sc)
    seen: dict[int, set] = {}
    try:
        tel.network.add_tap(lambda m: seen.setdefault(m.arbitration_id, set()).add(bytes(m.data[:1])))
        tel.client.power_on()
        tel.client.command_axis("ra", "track", 1)
        tel.client.command_dome("follow")
        tel.scheduler.run_until(tel.scheduler.now_us + 1_500_000)
    finally:
        tel.close()
    assert list(tel.boards) == list(R.BOARD_NAMES)
    sent_by_boards = set()
    for name, (spec, inst) in R.BOARDS.items():
        assert type(tel.boards[name]) is spec.firmware and tel.boards[name].node_id == inst.node_id
        sent_by_boards |= {cob for cob, _ in spec.sends(inst.node_id)}
    to_boards = {cob for spec, inst in R.BOARDS.values() for cob, _ in spec.accepts(inst.node_id)}
    board_frames = set(seen) - (to_boards - sent_by_boards)
    assert board_frames and board_frames <= sent_by_boards
    assert set(seen) <= sent_by_boards | to_boards       # nothing outside the registry's lists
    assert isinstance(tel.client.bus, can.BusABC)


def test_a_new_board_kind_is_one_firmware_class_and_one_registry_entry(tmp_path, monkeypatch):
    """A board kind the network has never seen (here a bare firmware in the focus node's place)
    is built, started, health-checked and reported from its registry entry alone: no edit in
    the assembly, the host or the report."""
    from boards.firmware_base import Board
    import host.network as N

    class Minimal(Board):
        DEVICE_TYPE = int(P.DeviceType.FOCUS_CONTROLLER)
        KIND = "minimal"
        CANOPEN_KIND = "focus_controller"        # its EDS (bus/eds/objects.py)

    spec = R.BoardSpec(kind="minimal", firmware=Minimal, device_type=P.DeviceType.FOCUS_CONTROLLER, ports=(),
                       instances=(R.BoardInstance("focus", P.NodeId.FOCUS),))
    monkeypatch.setattr(N, "BOARDS", {**R.BOARDS, "focus": (spec, spec.instances[0])})
    sc = parse_scenario("name: r\nsegments:\n  - {name: a, mode: stop, duration_s: 1}\n", str(tmp_path / "s.yaml"))
    tel = build_network(sc)
    try:
        assert type(tel.boards["focus"]) is Minimal
        assert tel.client.power_on().ok            # it answers the health check's SDO upload
        # the NMT start is delivered: through the USB gateway it leaves at the next 1 ms USB
        # frame, then takes its CAN frame time (docs/usb-gateway.md), so 2 ms, not 1 ms
        tel.scheduler.run_until(tel.scheduler.now_us + 2_000)
        rows = tel.board_summary()
    finally:
        tel.close()
    assert rows["focus"]["node"] == int(P.NodeId.FOCUS) and rows["focus"]["state"] == "OPERATIONAL"


def test_default_network_is_the_registry_default_boards(tmp_path):
    """Without a board list, build_network builds the registry's default boards (today's five)
    and the host's health check expects exactly those."""
    sc = parse_scenario("name: r\nsegments:\n  - {name: a, mode: stop, duration_s: 1}\n", str(tmp_path / "s.yaml"))
    tel = build_network(sc)
    try:
        assert tuple(tel.boards) == R.DEFAULT_BOARD_NAMES
        assert tel.client.expected_nodes == R.network_nodes("basic")      # the gateway is the host's node
        assert tel.client.expected_nodes == tuple(R.BOARDS[n][1].node_id for n in R.DEFAULT_BOARD_NAMES
                                                  if R.BOARDS[n][0].canopen)
    finally:
        tel.close()


def test_constants_of_compiled_modules_are_final():
    """Every module-level CONSTANT (upper-case name bound once) of a module compiled by mypyc
    (``bus._native.NATIVE_MODULES``) is ``typing.Final``: mypyc then inlines it or keeps it in a
    C static; otherwise each use is a module-dictionary lookup (≈ 5 % of the ``full`` network's
    instructions before session 8, docs/performance.md). Also a guard that none is rebound."""
    from bus._native import NATIVE_MODULES

    const = re.compile(r"^_?[A-Z][A-Z0-9_]*$")
    missing = []
    for mod in NATIVE_MODULES:
        path = ROOT / (mod.replace(".", "/") + ".py")
        tree = ast.parse(path.read_text(encoding="utf-8"))
        bound: dict[str, int] = {}
        for node in ast.walk(tree):
            if isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
                bound[node.id] = bound.get(node.id, 0) + 1
        rebound = {n for node in ast.walk(tree) if isinstance(node, ast.Global) for n in node.names}
        for node in tree.body:
            if isinstance(node, ast.Assign) and len(node.targets) == 1 and isinstance(node.targets[0], ast.Name):
                name = node.targets[0].id
            elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) and node.value is not None:
                name = node.target.id
                if "Final" in ast.unparse(node.annotation):
                    continue
            else:
                continue
            if const.match(name) and bound.get(name) == 1 and name not in rebound:
                missing.append(f"{mod}.{name} (line {node.lineno})")
    assert not missing, "module constants of compiled modules without typing.Final: " + ", ".join(missing)
