"""Presence, identity, frame length and the device-type byte of every node (generic: EDS + DBC)."""

from __future__ import annotations



def test_presence(node, conf, check):
    """The node is heard on the bus (boot-up or CiA heartbeat on 0x700 + node, DLC 1) and
    answers an SDO upload of 0x1000 with its EDS's device type (docs/protocol.md health check)."""
    if node.node_id not in conf.heard:         # --nodes given: wait one heartbeat period more
        st = conf.heartbeat_state(node.node_id, 1.5 * conf.heartbeat_period_s(node) + conf.slack)
        if st is not None:
            conf.heard[node.node_id] = st
    check("presence.heartbeat", node, "boot-up or heartbeat (0x700+node, DLC 1) within the listen window "
          "(with --nodes: or within 1.5 heartbeat periods more)",
          "heard, state 0x%02X" % conf.heard[node.node_id] if node.node_id in conf.heard else "not heard",
          node.node_id in conf.heard)
    word = node.remote.sdo[0x1000].raw
    documented = int(node.od[0x1000].default)
    check("identity.device_type", node, f"0x1000 = 0x{documented:08X} (EDS {node.kind.name})",
          f"0x{word:08X}", word == documented)


def test_identity(node, check):
    """0x1018 vendor id, product code and revision, 0x1008 device name and 0x100A software
    version read by SDO equal the node's EDS (the serial number is reported: a real board
    answers its own)."""
    for sub, name in ((1, "vendor_id"), (2, "product_code"), (3, "revision")):
        want = int(node.od[0x1018][sub].default)
        got = node.remote.sdo[0x1018][sub].raw
        check(f"identity.{name}", node, f"0x1018:{sub} = 0x{want:08X}", f"0x{got:08X}", got == want)
    serial = node.remote.sdo[0x1018][4].raw
    want = int(node.od[0x1018][4].default)
    for index, name in ((0x1008, "device_name"), (0x100A, "software_version")):
        doc = str(node.od[index].default)
        got = node.remote.sdo[index].raw
        extra = f" (serial 0x{serial:08X}, EDS predicts 0x{want:08X})" if index == 0x1008 else ""
        check(f"identity.{name}", node, f"0x{index:04X} = {doc!r}", f"{got!r}{extra}", got == doc)


def test_frame_lengths_and_device_type(node, conf, check, traffic):
    """Every frame the node sent during the capture has the DBC's DLC; byte 0 of its PDOs is the
    device type the DBC fixes (signal device_type, minimum = maximum) and equals 0x1000's byte;
    its heartbeat is one byte."""
    mine = {node.node_id + 0x700, node.node_id + 0x80, node.node_id + 0x580} | set(node.tpdos)
    seen = [f for f in traffic if f.cob_id in mine]
    periodic = conf.periodic_tpdos(node)
    check("frames.cycle_times_agree", node, "DBC GenMsgCycleTime = EDS event timer (0x18xx:5) of each cyclic TPDO",
          {f"0x{c:03X}": (ms, node.tpdos[c]) for c, ms in periodic.items()},
          all(node.tpdos[c] == ms for c, ms in periodic.items()))
    check("frames.periodic_seen", node, "every cyclic TPDO (DBC GenMsgCycleTime) is sent",
          {f"0x{c:03X}": sum(1 for f in seen if f.cob_id == c) for c in periodic},
          all(any(f.cob_id == c for f in seen) for c in periodic))
    bad_dlc, bad_dt, undocumented = [], [], set()
    for f in seen:
        m = conf.docs.message(f.cob_id)
        if m is None:
            undocumented.add(f.cob_id)
            continue
        if len(f.data) != m.length:
            bad_dlc.append(f"0x{f.cob_id:03X} DLC {len(f.data)} != {m.length}")
        if f.cob_id in node.tpdos:
            fixed = conf.docs.fixed_device_type(f.cob_id)
            if fixed is None or f.data[:1] != bytes((fixed,)) or fixed != node.kind.device_type:
                bad_dt.append(f"0x{f.cob_id:03X} byte0 {f.data[:1].hex()} (DBC {fixed}, "
                              f"0x1000 {node.kind.device_type})")
    check("frames.documented_ids", node, "every identifier the node sends is a DBC message",
          sorted(hex(c) for c in undocumented) or "all documented", not undocumented)
    check("frames.dlc", node, "DLC = the DBC message length", bad_dlc[:5] or f"{len(seen)} frames ok",
          not bad_dlc)
    check("frames.device_type", node, "PDO byte 0 = the DBC's fixed device_type = 0x1000 bits 16-23",
          bad_dt[:5] or f"0x{node.kind.device_type:02X} in every PDO", not bad_dt)
