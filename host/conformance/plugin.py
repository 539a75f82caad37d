"""pytest plugin of the conformance suite: options, the bus, the node inventory, the check records.

Loaded by ``host/conformance/conftest.py``, so the suite runs under ``schmidt-fil conform`` or
plain ``pytest host/conformance -o python_files='check_*.py' --cf-...``.

* ``--cf-interface``/``--cf-channel``: a python-can bus in real time; without it the in-process
  emulator of ``--cf-scenario`` in simulated time.
* Nodes: ``--cf-nodes 1,3,5`` or every node heard (boot-up or heartbeat) in the first
  ``--cf-listen`` seconds. Each node's kind is its answer to an SDO upload of 0x1000 matched to
  the EDS files (device-type byte in bits 16–23): nodes of a kind added later get every generic
  check from their EDS and the DBC, with no new code.
* Checks: tests call the ``check`` fixture (``check(id, node, documented, observed, passed)``);
  every check is recorded (``conformance.json``/``.md``) and a test fails when one of its
  asserted checks fails. ``--cf-timing report`` records timing checks without asserting them
  (a software-emulated guest runs slower than real time).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional

import pytest

from host.conformance.documents import KindDoc, NMT_CS, load_documents
from host.conformance.link import Frame, HOST_NODE, Link

__all__ = ["Conformance", "NodeInfo", "Check"]

_CONF: Optional["Conformance"] = None


def pytest_addoption(parser):
    g = parser.getgroup("conformance", "schmidt-fil conformance suite")
    g.addoption("--cf-interface", default=None,
                help="python-can interface (socketcan, virtual, ...); default: the in-process emulator")
    g.addoption("--cf-channel", default=None, help="python-can channel (vcan0, can0)")
    g.addoption("--cf-bitrate", type=int, default=None, help="bitrate for interfaces that set it")
    g.addoption("--cf-scenario", default=None, help="scenario of the in-process emulator")
    g.addoption("--cf-nodes", default=None, help="comma-separated node ids (default: every node heard)")
    g.addoption("--cf-listen", type=float, default=1.3,
                help="seconds to listen for boot-ups/heartbeats when --cf-nodes is not given")
    g.addoption("--cf-allow-motion", default=None, choices=("yes", "no"),
                help="run checks that move an axis or the focus (default: yes in-process, no on a real bus)")
    g.addoption("--cf-timing", default="assert", choices=("assert", "report"),
                help="assert timing checks, or only report them")
    g.addoption("--cf-capture", type=float, default=5.5,
                help="seconds of periodic traffic captured for the period and jitter checks")
    g.addoption("--cf-reaction-slack", type=float, default=0.0,
                help="seconds added to every reaction timeout on a real bus (with --cf-clock wall)")
    g.addoption("--cf-clock", default="device", choices=("device", "wall"),
                help="on a real bus, wait on the devices' clock (counted from their periodic frames; "
                     "default) or on the wall clock")
    g.addoption("--cf-min-rate", type=float, default=0.05,
                help="device clock: a wait of dt gives up after dt / this many wall seconds")
    g.addoption("--cf-emulator-rate", type=float, default=None,
                help="test aid: run the in-process emulator at this fraction of a virtual wall clock "
                     "(bursty, seeded) and wait as on a real bus")
    g.addoption("--cf-emulator-seed", type=int, default=1, help="seed of --cf-emulator-rate's bursts")
    g.addoption("--cf-emulator-host-stall", default=None, metavar="COB:SECONDS",
                help="test aid (with --cf-emulator-rate): after the host's first frame on COB (e.g. "
                     "0x201), the emulator runs SECONDS while the host neither reads nor beats")
    g.addoption("--cf-out", default=None, help="write conformance.json and conformance.md here")


def pytest_configure(config):
    config.addinivalue_line("markers", "timing: a timing check (asserted unless --cf-timing report)")
    config.addinivalue_line("markers", "motion: moves an axis or the focus (needs motion allowed)")


@dataclass
class NodeInfo:
    """A node under test, as its EDS describes it."""

    node_id: int
    kind: KindDoc
    od: object
    remote: object                                # canopen.RemoteNode
    tpdos: Dict[int, int] = field(default_factory=dict)   # COB-ID -> event timer ms (0 = event)
    rpdos: List[int] = field(default_factory=list)

    @property
    def label(self) -> str:
        return f"node{self.node_id}"

    def __str__(self) -> str:
        return f"node {self.node_id} ({self.kind.name})"


@dataclass
class CheckRecord:
    id: str
    node: Optional[int]
    documented: str
    observed: str
    passed: Optional[bool]
    kind: str                 # "functional" | "timing"
    asserted: bool
    test: str


class Conformance:
    """The session: documents, link, nodes, records (one per pytest session)."""

    def __init__(self, config):
        self.config = config
        self.opt = lambda name: config.getoption(name)
        self.docs = load_documents()
        slack = float(config.getoption("--cf-reaction-slack") or 0.0)
        if slack:
            from dataclasses import replace
            t = self.docs.tolerances
            self.docs.tolerances = replace(t, nmt_reaction_s=t.nmt_reaction_s + slack,
                                           command_reaction_s=t.command_reaction_s + slack)
        self.slack = slack
        self.records: List[CheckRecord] = []
        self.link: Optional[Link] = None
        self._nodes: Optional[List[NodeInfo]] = None
        self.setup_error: Optional[str] = None
        self.heard: Dict[int, int] = {}
        self.lateness: Optional[dict] = None
        #: tests run again because the host's own heartbeat lapsed (:func:`pytest_pyfunc_call`)
        self.reruns: List[dict] = []

    # ------------------------------------------------------------------ the bus
    @property
    def in_process(self) -> bool:
        return self.opt("--cf-interface") in (None, "", "emulator")

    @property
    def motion_allowed(self) -> bool:
        v = self.opt("--cf-allow-motion")
        return self.in_process if v is None else v == "yes"

    @property
    def timing_asserted(self) -> bool:
        return self.opt("--cf-timing") == "assert"

    def device_clock(self):
        """A :class:`~host.conformance.link.DeviceClock` from the documents: every DBC message
        with a cycle time is a periodic stream; the heartbeat is one at the EDS 0x1017 period if
        all EDS files give the same (else heartbeats are not counted)."""
        from host.conformance.link import DeviceClock
        periods = {m.frame_id: m.cycle_time / 1000.0 for m in self.docs.dbc.messages if m.cycle_time}
        hb = {int(k.od(1)[0x1017].default) for k in self.docs.kinds.values()}
        tol = self.docs.tolerances
        return DeviceClock(periods, hb.pop() / 1000.0 if len(hb) == 1 and 0 not in hb else None,
                           pdo_jitter_s=tol.pdo_jitter_s, heartbeat_jitter_s=tol.heartbeat_jitter_s)

    def open(self) -> Link:
        if self.link is None:
            device = self.opt("--cf-clock") == "device"
            min_rate = float(self.opt("--cf-min-rate"))
            if not 0 < min_rate <= 1:
                raise pytest.UsageError(f"--min-rate: expected 0 < rate <= 1, got {min_rate}")
            if self.in_process:
                from host.conformance.emulator import open_emulator_link
                scen = self.opt("--cf-scenario")
                rate = self.opt("--cf-emulator-rate")
                if rate is not None and not 0 < rate <= 1:
                    raise pytest.UsageError(f"--cf-emulator-rate: expected 0 < rate <= 1, got {rate}")
                stall = self.opt("--cf-emulator-host-stall")
                if stall is not None:
                    try:
                        cob, seconds = stall.split(":")
                        stall = (int(cob, 0), float(seconds))
                    except ValueError:
                        raise pytest.UsageError(f"--cf-emulator-host-stall: expected COB:SECONDS "
                                                f"(e.g. 0x201:3), got {stall!r}") from None
                    if rate is None:
                        raise pytest.UsageError("--cf-emulator-host-stall needs --cf-emulator-rate")
                self.link = open_emulator_link(
                    Path(scen) if scen else None, rate=rate, seed=self.opt("--cf-emulator-seed"),
                    host_stall=stall,
                    device_clock=self.device_clock() if rate is not None and device else None,
                    sdo_timeout_s=0.02 if rate is None else 0.1 + self.slack, min_rate=min_rate)
            else:
                from host.conformance.link import open_real_link
                channel = self.opt("--cf-channel")
                if not channel:
                    raise pytest.UsageError("--cf-channel is required with --cf-interface")
                self.link = open_real_link(self.opt("--cf-interface"), channel,
                                           self.opt("--cf-bitrate"), sdo_timeout_s=0.1 + self.slack,
                                           device_clock=self.device_clock() if device else None,
                                           min_rate=min_rate)
        return self.link

    # ------------------------------------------------------------------ the nodes
    def nodes(self) -> List[NodeInfo]:
        """Discover (once) and identify the nodes under test."""
        if self._nodes is not None:
            return self._nodes
        link = self.open()
        listen_s = self.opt("--cf-listen") + self.slack
        heard = link.wait(listen_s)
        for f in heard:
            if 0x701 <= f.cob_id <= 0x77F and len(f.data) == 1:
                self.heard.setdefault(f.cob_id - 0x700, f.data[0])
        given = self.opt("--cf-nodes")
        if given:
            try:
                ids = [int(x, 0) for x in given.split(",") if x.strip()]
            except ValueError:
                raise pytest.UsageError(f"--nodes: expected comma-separated node ids, got {given!r}")
            bad = [i for i in ids if not 1 <= i <= 127]
            if bad:
                raise pytest.UsageError(f"--nodes: node ids are 1..127, got {bad}")
        else:
            ids = sorted(n for n in self.heard if n != HOST_NODE)
        self.records.append(CheckRecord(
            "presence.nodes", None, "at least one node to check (--nodes, or heard on 0x701-0x77F)",
            f"heard {sorted(self.heard) or 'none'} in {listen_s:g} s ({len(heard)} frames); checking {ids}",
            bool(ids), "functional", True, "session"))
        nodes = []
        for nid in ids:
            info = self._identify(nid)
            if info is not None:
                nodes.append(info)
        self._nodes = nodes
        return nodes

    def _identify(self, nid: int) -> Optional[NodeInfo]:
        """SDO upload of 0x1000 with a generic dictionary; the device-type byte picks the EDS."""
        import canopen
        link = self.link
        probe = canopen.ObjectDictionary()
        probe.add_object(canopen.objectdictionary.ODVariable("Device type", 0x1000, 0))
        probe[0x1000].data_type = canopen.objectdictionary.UNSIGNED32
        node = link.master.add_remote(nid, probe)
        try:
            word = int(node.sdo.upload(0x1000, 0)[0:4][::-1].hex(), 16)
        except Exception as exc:   # SdoCommunicationError / SdoAbortedError: recorded, not fatal
            self.records.append(CheckRecord(
                "presence.sdo_0x1000", nid, "answers an SDO upload of 0x1000 (docs/protocol.md health check)",
                f"no answer ({exc})", False, "functional", True, "session"))
            return None
        finally:
            if nid in link.master:
                del link.master[nid]
        kind = self.docs.kind_of_device_type((word >> 16) & 0xFF)
        if kind is None:
            self.records.append(CheckRecord(
                "presence.kind", nid, f"0x1000 device type of a documented kind "
                f"({', '.join(f'0x{k.device_type:02X} {k.name}' for k in self.docs.kinds.values())})",
                f"0x{word:08X}", False, "functional", True, "session"))
            return None
        od = kind.od(nid)
        remote = link.master.add_remote(nid, od)
        info = NodeInfo(nid, kind, od, remote)
        for idx in range(0x1800, 0x1A00):
            if idx in od:
                rec = od[idx]
                cob = int(rec[1].default) & 0x7FF
                timer = int(rec[5].default) if 5 in rec else 0
                info.tpdos[cob] = timer
        for idx in range(0x1400, 0x1600):
            if idx in od:
                info.rpdos.append(int(od[idx][1].default) & 0x7FF)
        return info

    # ------------------------------------------------------------------ helpers for checks
    def nmt(self, node: int, command: str) -> None:
        """Send NMT ``command`` (CiA 301 specifier) to ``node`` (0 = all)."""
        self.link.send(0x000, bytes((NMT_CS[command], node)))

    def heartbeat_state(self, node: int, timeout_s: float) -> Optional[int]:
        """The next heartbeat state byte of ``node`` within ``timeout_s`` (None if none)."""
        f = self.link.pump_until(lambda f: f.cob_id == 0x700 + node and len(f.data) == 1, timeout_s)
        return None if f is None else f.data[0]

    def periodic_tpdos(self, node: NodeInfo) -> Dict[int, int]:
        """``{COB-ID: period ms}`` of the node's TPDOs the DBC documents as cyclic
        (GenMsgCycleTime); an event-driven TPDO with a repeat timer (LIMIT) is not one."""
        out = {}
        for cob in node.tpdos:
            m = self.docs.message(cob)
            if m is not None and m.cycle_time:
                out[cob] = int(m.cycle_time)
        return out

    def heartbeat_period_s(self, node: NodeInfo) -> float:
        """The documented producer heartbeat time (EDS 0x1017), s."""
        return int(node.od[0x1017].default) / 1000.0

    def clock_resolution_s(self) -> float:
        """How far the link's time may lag the nodes' own, s: 0 in simulated or wall-clock time;
        on the devices' clock the period of the fastest stream heard (it counts frames, so it is
        no finer than they come; :meth:`~host.conformance.link.DeviceClock.resolution_s`)."""
        if self.link is None or self.link.clock is None:
            return 0.0
        return self.link.clock.resolution_s()

    def ensure_operational(self, node: NodeInfo) -> None:
        self.nmt(node.node_id, "start")
        self.link.wait(0.05)


class Check:
    """The ``check`` fixture: records checks of one test; failures fail the test at its end."""

    def __init__(self, conf: Conformance, test: str):
        self.conf = conf
        self.test = test
        self.failures: List[str] = []

    def __call__(self, id: str, node, documented: str, observed, passed: bool,
                 timing: bool = False) -> bool:
        asserted = not timing or self.conf.timing_asserted
        nid = node.node_id if isinstance(node, NodeInfo) else node
        rec = CheckRecord(id, nid, documented, str(observed), bool(passed),
                          "timing" if timing else "functional", asserted, self.test)
        self.conf.records.append(rec)
        if not passed and asserted:
            self.failures.append(f"{id} (node {nid}): documented {documented}; observed {observed}")
        return bool(passed)


def _conf(config) -> Conformance:
    global _CONF
    if _CONF is None or _CONF.config is not config:
        _CONF = Conformance(config)
    return _CONF


# --------------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="session")
def conf(request) -> Conformance:
    return _conf(request.config)


@pytest.fixture
def check(request, conf) -> Check:
    c = Check(conf, request.node.nodeid)
    request.node._cf_check = c
    return c


def _has_rpdo_message(conf: Conformance, n: NodeInfo, prefix: str) -> bool:
    for cob in n.rpdos:
        m = conf.docs.message(cob)
        if m is not None and m.name.startswith(prefix):
            return True
    return False


def pytest_generate_tests(metafunc):
    conf = _conf(metafunc.config)
    for name, pick in (("node", lambda n: True),
                       ("axis_node", lambda n: _has_rpdo_message(conf, n, "AXIS_COMMAND")),
                       ("focus_node", lambda n: _has_rpdo_message(conf, n, "FOCUS_COMMAND"))):
        if name in metafunc.fixturenames:
            try:
                nodes = [n for n in conf.nodes() if pick(n)]
            except pytest.UsageError:
                raise
            except Exception as exc:
                raise pytest.UsageError(f"conformance: cannot reach the bus: {exc}") from None
            metafunc.parametrize(name, nodes, ids=[n.label for n in nodes], scope="function")


def pytest_collection_modifyitems(config, items):
    conf = _conf(config)
    skip_motion = pytest.mark.skip(reason="moves hardware: run with --allow-motion")
    for item in items:
        if "motion" in item.keywords and not conf.motion_allowed:
            item.add_marker(skip_motion)


#: How many times a test is run again when the host's own heartbeat lapsed during it.
HOST_LAPSE_RERUNS = 2


def host_lapses(conf: Conformance, first_frame: int) -> List[str]:
    """The devices' own statements, in the frames received from index ``first_frame`` on, that
    the conformance host's heartbeat lapsed: an EMCY HEARTBEAT_LOST naming the host (detail
    0x10) or an EMCY HOST_TIMEOUT (an axis controller's host watchdog, docs/faults.md), each
    with the error register set (not the reset). One line each."""
    from host.conformance.check_malformed import emcy_frames
    codes = {conf.docs.emcy(name): name for name in ("HEARTBEAT_LOST", "HOST_TIMEOUT")
             if name in conf.docs.emcy_codes}
    out: List[str] = []
    frames = conf.link.frames if conf.link is not None else []
    for f in frames[first_frame:]:
        if 0x81 <= f.cob_id <= 0xFF:
            for t, code, reg, _fault, detail, _n in emcy_frames([f], f.cob_id - 0x80):
                name = codes.get(code)
                if reg and name and (name != "HEARTBEAT_LOST" or detail == HOST_NODE):
                    out.append(f"node {f.cob_id - 0x80} EMCY {name} at {t:.3f} s")
    return out


def _longest_beat_gap_s(link: Link, first_sent: int) -> float:
    """Longest wall-clock gap between the host's heartbeats sent from index ``first_sent`` on."""
    walls = [f.wall for f in link.sent[first_sent:] if f.cob_id == 0x700 + HOST_NODE]
    return max((b - a for a, b in zip(walls, walls[1:])), default=0.0)


@pytest.hookimpl(wrapper=True)
def pytest_pyfunc_call(pyfuncitem):
    """Run a conformance test again (at most :data:`HOST_LAPSE_RERUNS` times) when it failed
    while the devices said the *host's* heartbeat lapsed and the test did not silence the host
    on purpose.

    A check measures a device only while the host keeps its own side of the protocol: an axis
    whose host watchdog fired (2 s without the host, docs/faults.md) stops, as it must, and a
    rate check then fails for the host's fault. The QEMU guest's emulated CPUs deschedule the
    host process for seconds at a time (docs/conformance.md, "The host's own heartbeat"). The
    failed attempt's checks are not counted; they are kept in :attr:`Conformance.reruns` and the
    report with the devices' EMCY that proved the lapse. A lapse in every attempt leaves the
    last attempt's failures standing."""
    conf = _conf(pyfuncitem.config)
    link = conf.link
    chk: Optional[Check] = getattr(pyfuncitem, "_cf_check", None)
    if link is None or chk is None or getattr(pyfuncitem, "_cf_rerunning", False):
        return (yield)
    attempt = 0
    while True:
        first_frame, first_sent, first_rec = len(link.frames), len(link.sent), len(conf.records)
        silences = link.silences
        try:
            if attempt == 0:
                result = yield
            else:
                pyfuncitem._cf_rerunning = True
                try:
                    result = pyfuncitem.ihook.pytest_pyfunc_call(pyfuncitem=pyfuncitem)
                finally:
                    pyfuncitem._cf_rerunning = False
            error = None
        except Exception as exc:          # a check's exception (SDO timeout, assertion)
            result, error = None, exc
        failed = bool(chk.failures) or error is not None
        lapses = host_lapses(conf, first_frame) if failed and link.silences == silences else []
        if not lapses or attempt >= HOST_LAPSE_RERUNS:
            if error is not None:
                raise error
            return result
        conf.reruns.append({
            "test": pyfuncitem.nodeid, "attempt": attempt + 1, "lapses": lapses,
            "host_longest_beat_gap_wall_s": round(_longest_beat_gap_s(link, first_sent), 3),
            "failed": list(chk.failures) + ([f"{type(error).__name__}: {error}"] if error else []),
            "checks_not_counted": len(conf.records) - first_rec})
        del conf.records[first_rec:]
        chk.failures.clear()
        attempt += 1


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    rep = outcome.get_result()
    if rep.when != "call":
        return
    chk: Optional[Check] = getattr(item, "_cf_check", None)
    conf = _conf(item.config)
    if rep.passed and chk is not None and chk.failures:
        rep.outcome = "failed"
        rep.longrepr = "\n".join(chk.failures)
    elif rep.failed and call.excinfo is not None and not call.excinfo.errisinstance(AssertionError):
        node = None
        for key in ("node", "axis_node", "focus_node"):
            if key in getattr(item, "funcargs", {}):
                node = item.funcargs[key].node_id
        conf.records.append(CheckRecord(item.name, node, "the check runs to its end",
                                        call.excinfo.exconly().splitlines()[0][:300], False,
                                        "functional", True, item.nodeid))


def pytest_sessionfinish(session, exitstatus):
    conf = _CONF
    if conf is None or conf.config is not session.config:
        return
    out = conf.opt("--cf-out")
    try:
        if out:
            from host.conformance.report import write_reports
            write_reports(Path(out), conf)
    finally:
        if conf.link is not None:
            conf.link.close()
        if any(r.passed is False and r.asserted for r in conf.records) and session.exitstatus == 0:
            session.exitstatus = 1


def stats(values: List[float]) -> dict:
    """mean, min, max and 99th percentile (nearest rank) of ``values``."""
    v = sorted(values)
    if not v:
        return {"n": 0}
    k = max(0, min(len(v) - 1, math.ceil(0.99 * len(v)) - 1))
    return {"n": len(v), "mean": sum(v) / len(v), "min": v[0], "max": v[-1], "p99": v[k]}


def intervals(frames: List[Frame], cob_id: int) -> List[float]:
    """Intervals between successive frames with identifier ``cob_id``, s, on the receiver's
    clock (``Frame.wall``: simulated time in-process, the kernel's timestamps on a real bus) —
    never on the devices' clock, which is counted from these very periods."""
    t = [f.wall for f in frames if f.cob_id == cob_id]
    return [b - a for a, b in zip(t, t[1:])]


@pytest.fixture(scope="session")
def traffic(conf) -> List[Frame]:
    """Every frame of ``--cf-capture`` seconds with all nodes under test OPERATIONAL, at rest."""
    # one broadcast NMT start (the health check's), not one frame per node: a board whose
    # emulator runs late receives a burst of frames at once, and its CAN receive buffers are 2 deep
    conf.nmt(0, "start")
    conf.link.wait(0.2 + conf.slack)
    return conf.link.wait(conf.opt("--cf-capture"))
