"""NMT (CiA 301 §7.2.8, docs/canopen.md "NMT behaviour"): start, stop, pre-operational, reset
node, reset communication; a node that is not OPERATIONAL sends no PDO."""

from __future__ import annotations


def _state_after(conf, node, command):
    """Send NMT ``command`` to the node; the state of its first heartbeat after the reaction time."""
    tol = conf.docs.tolerances
    conf.nmt(node.node_id, command)
    conf.link.wait(tol.nmt_reaction_s)
    return conf.heartbeat_state(node.node_id, conf.heartbeat_period_s(node) + tol.nmt_reaction_s)


def _pdos_in(conf, node, window_s):
    got = conf.link.wait(window_s)
    return sorted({f"0x{f.cob_id:03X}" for f in got if f.cob_id in node.tpdos})


def _silence_window(conf, node) -> float:
    """Long enough to see every cyclic TPDO twice."""
    periods = list(conf.periodic_tpdos(node).values()) or [100]
    return max(0.3, 2.0 * max(periods) / 1000.0)


def _sdo_answers(node, index=0x1000) -> bool:
    try:
        node.remote.sdo[index].raw
        return True
    except Exception:          # SdoCommunicationError (no answer)
        return False


def _check_pdos_resume(conf, node, check, id_):
    window = _silence_window(conf, node)
    got = {f.cob_id for f in conf.link.wait(window)}
    missing = [f"0x{c:03X}" for c in conf.periodic_tpdos(node) if c not in got]
    check(id_, node, f"every cyclic TPDO within {window * 1e3:g} ms of NMT start",
          missing and f"missing {missing}" or "all seen", not missing)


def test_nmt_pre_operational_and_start(node, conf, check):
    """Pre-operational: heartbeat 0x7F, no PDO, SDO answered; start: heartbeat 0x05, PDOs again."""
    conf.ensure_operational(node)
    st = _state_after(conf, node, "pre-operational")
    check("nmt.pre_operational.state", node, "heartbeat 0x7F after NMT pre-operational (0x80)", st, st == 0x7F)
    pdos = _pdos_in(conf, node, _silence_window(conf, node))
    check("nmt.pre_operational.no_pdo", node, "no TPDO while PRE-OPERATIONAL", pdos or "none", not pdos)
    ok = _sdo_answers(node)
    check("nmt.pre_operational.sdo", node, "SDO answered while PRE-OPERATIONAL", ok, ok)
    st = _state_after(conf, node, "start")
    check("nmt.start.state", node, "heartbeat 0x05 after NMT start (0x01)", st, st == 0x05)
    _check_pdos_resume(conf, node, check, "nmt.start.pdos")


def test_nmt_stop(node, conf, check):
    """Stopped: heartbeat 0x04, no PDO and no SDO answer (docs/canopen.md); start brings it back."""
    conf.ensure_operational(node)
    st = _state_after(conf, node, "stop")
    check("nmt.stop.state", node, "heartbeat 0x04 after NMT stop (0x02)", st, st == 0x04)
    pdos = _pdos_in(conf, node, _silence_window(conf, node))
    check("nmt.stop.no_pdo", node, "a stopped node sends no PDO", pdos or "none", not pdos)
    ok = _sdo_answers(node)
    check("nmt.stop.no_sdo", node, "no SDO answer while STOPPED", "answered" if ok else "no answer", not ok)
    st = _state_after(conf, node, "start")
    check("nmt.stop.restart", node, "heartbeat 0x05 after NMT start", st, st == 0x05)
    _check_pdos_resume(conf, node, check, "nmt.stop.pdos_resume")


def _boot_up(conf, node, command):
    """Send NMT ``command``; the boot-up frame (``00`` on 0x700 + node) within the NMT reaction
    time, or None. At most one heartbeat may come before it: one the node had sent before the
    command reached it (in flight; a slow emulator has several ms of them). A second one means
    the node went on beating for a period instead of resetting: then None."""
    tol = conf.docs.tolerances
    cob = 0x700 + node.node_id
    earlier = []

    def boot_or_count(f):
        if f.cob_id != cob:
            return False
        if f.data == b"\x00" or len(earlier) >= 1:
            return True
        earlier.append(f)
        return False

    conf.nmt(node.node_id, command)
    boot = conf.link.pump_until(boot_or_count, tol.nmt_reaction_s)
    return boot


def test_nmt_reset_communication(node, conf, check):
    """Reset communication: boot-up message (0x00), then PRE-OPERATIONAL (heartbeat 0x7F, no PDO)."""
    conf.ensure_operational(node)
    boot = _boot_up(conf, node, "reset communication")
    check("nmt.reset_communication.boot_up", node, "boot-up 0x00 on 0x700+node after NMT 0x82 (at most one "
          "heartbeat sent before the command arrived first)",
          boot and boot.data.hex(), boot is not None and boot.data == b"\x00")
    st = conf.heartbeat_state(node.node_id, conf.heartbeat_period_s(node) + conf.docs.tolerances.nmt_reaction_s)
    check("nmt.reset_communication.pre_operational", node, "then heartbeat 0x7F", st, st == 0x7F)
    pdos = _pdos_in(conf, node, _silence_window(conf, node))
    check("nmt.reset_communication.no_pdo", node, "no TPDO until NMT start", pdos or "none", not pdos)
    st = _state_after(conf, node, "start")
    check("nmt.reset_communication.restart", node, "heartbeat 0x05 after NMT start", st, st == 0x05)


def test_nmt_reset_node(node, conf, check):
    """Reset node: boot-up, PRE-OPERATIONAL; where the EDS has the diagnostics record 0x2F00, the
    reset count (sub 2) goes up by one and the reset cause (sub 3) reads 2 SOFTWARE."""
    conf.ensure_operational(node)
    diag = 0x2F00 in node.od
    before = node.remote.sdo[0x2F00][2].raw if diag else None
    boot = _boot_up(conf, node, "reset node")
    check("nmt.reset_node.boot_up", node, "boot-up 0x00 on 0x700+node after NMT 0x81 (at most one "
          "heartbeat sent before the command arrived first)",
          boot and boot.data.hex(), boot is not None and boot.data == b"\x00")
    st = conf.heartbeat_state(node.node_id, conf.heartbeat_period_s(node) + conf.docs.tolerances.nmt_reaction_s)
    check("nmt.reset_node.pre_operational", node, "then heartbeat 0x7F", st, st == 0x7F)
    if diag:
        after = node.remote.sdo[0x2F00][2].raw
        cause = node.remote.sdo[0x2F00][3].raw
        check("nmt.reset_node.count", node, "0x2F00:2 reset count + 1", f"{before} -> {after}",
              after == (before + 1) % 0x10000)
        check("nmt.reset_node.cause", node, f"0x2F00:3 = 2 ({node.od[0x2F00][3].description or 'SOFTWARE'})",
              cause, cause == 2)
    st = _state_after(conf, node, "start")
    check("nmt.reset_node.restart", node, "heartbeat 0x05 after NMT start", st, st == 0x05)
    _check_pdos_resume(conf, node, check, "nmt.reset_node.pdos_resume")
