"""Malformed frames (docs/protocol.md "Encoding and decoding rules"): a frame on an id the node
accepts that does not decode is counted in 0x2F00:1 and answered with EMCY MALFORMED_FRAME
(detail = its COB-ID); the node keeps running."""

from __future__ import annotations

import struct

import pytest


def emcy_frames(frames, node_id):
    """EMCY frames of ``node_id`` decoded by the documented layout: (t, code, register, fault, detail, count)."""
    out = []
    for f in frames:
        if f.cob_id == 0x80 + node_id and len(f.data) == 8:
            code, reg, fault, detail, count = struct.unpack("<HBBHH", f.data)
            out.append((f.t, code, reg, fault, detail, count))
    return out


#: docs/faults.md, fault 1: "FAULT sent for a burst of 4 then ≤ 10 per s" (EMCY) -> 100 ms apart.
MALFORMED_EMCY_INTERVAL_S = 0.1


def _cases(conf, node):
    """(label, cob_id, data): a wrong DLC and a wrong device-type byte on every RPDO of the node
    (their DBC layouts), and an SDO request of DLC 4."""
    cases = []
    for cob in node.rpdos:
        msg = conf.docs.message(cob)
        fixed = conf.docs.fixed_device_type(cob)
        if msg is None or fixed is None:
            continue
        cases.append((f"{msg.name} DLC 3", cob, bytes((fixed, 0, 0))))
        cases.append((f"{msg.name} device type 0x{fixed ^ 0xFF:02X}", cob, bytes((fixed ^ 0xFF,) + (0,) * 7)))
    cases.append(("SDO request DLC 4", 0x600 + node.node_id, bytes((0x40, 0x00, 0x10, 0x00))))
    return cases


def test_malformed_frames_counted(node, conf, check):
    """Each malformed frame adds one to 0x2F00:1 and brings EMCY 0x8200 with detail = the COB-ID;
    afterwards the node still answers SDO and sends its heartbeat and PDOs."""
    if 0x2F00 not in node.od:
        pytest.skip("the EDS has no diagnostics record 0x2F00")
    conf.ensure_operational(node)
    code = conf.docs.emcy("MALFORMED_FRAME")
    for label, cob, data in _cases(conf, node):
        before = node.remote.sdo[0x2F00][1].raw
        t0 = conf.link.now()
        conf.link.send(cob, data)
        # docs/faults.md: the EMCY for malformed frames comes for a burst of 4, then at most 10
        # per second; spacing the cases by 100 ms keeps every one within that documented rate
        conf.link.wait(max(conf.docs.tolerances.command_reaction_s, MALFORMED_EMCY_INTERVAL_S))
        after = node.remote.sdo[0x2F00][1].raw
        check(f"malformed.count[{label}]", node, "0x2F00:1 + 1", f"{before} -> {after}",
              after == min(before + 1, 0xFFFF))
        em = [e for e in emcy_frames(conf.link.frames_of(0x80 + node.node_id), node.node_id) if e[0] >= t0 and e[1] == code]
        check(f"malformed.emcy[{label}]", node, f"EMCY 0x{code:04X} detail 0x{cob:03X}",
              [f"0x{e[1]:04X} detail 0x{e[4]:03X}" for e in em] or "none",
              any(e[4] == cob for e in em))
    window = max([0.3] + [2 * ms / 1000 for ms in conf.periodic_tpdos(node).values()])
    hb = conf.heartbeat_period_s(node) + conf.docs.tolerances.nmt_reaction_s
    got = conf.link.wait(max(window, hb))
    ids = {f.cob_id for f in got}
    missing = [f"0x{c:03X}" for c in list(conf.periodic_tpdos(node)) + [0x700 + node.node_id] if c not in ids]
    check("malformed.keeps_running", node, "heartbeat and cyclic TPDOs go on after the malformed frames",
          missing and f"missing {missing}" or "all seen", not missing)
    beat = [f.data[0] for f in got if f.cob_id == 0x700 + node.node_id]
    check("malformed.still_operational", node, "heartbeat state 0x05", beat, bool(beat) and set(beat) == {5})
