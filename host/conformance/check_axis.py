"""Axis commands (every node with an AXIS_COMMAND RPDO in the DBC): each command's documented
effect, the refusal of values outside the DBC's ranges, soft-limit behaviour.

The axis's position reader is found from the EDS files (the node whose TPDO the axis consumes
as its LIMIT RPDO); rates are measured from its POSITION frames (signal ``pos_counts``, the
DBC's "2**29 per revolution"), not from the axis's own report.
"""

from __future__ import annotations

import re

import pytest

from host.conformance.check_malformed import emcy_frames

pytestmark = pytest.mark.motion

#: 360 × 3600″ — written here, not imported from bus.units: the suite uses none of the project's code.
_ARCSEC_PER_TURN = 360 * 3600.0
#: docs/boards.md, position reader "Soft limits": a limit flag clears once the axis is back inside
#: by this much (and no longer moving toward the limit), ″.
LIMIT_HYSTERESIS_ARCSEC = 10.0


class Axis:
    """An axis controller node and its reader, as the DBC and EDS files describe them."""

    def __init__(self, conf, node):
        self.conf, self.node, self.link, db = conf, node, conf.link, conf.docs
        self.cmd_cob = next(c for c in node.rpdos if db.message(c) is not None
                            and db.message(c).name.startswith("AXIS_COMMAND"))
        self.cmd_msg = db.message(self.cmd_cob)
        self.cmds = {str(v): k for k, v in self.cmd_msg.get_signal_by_name("cmd").choices.items()}
        self.status_cob = next(c for c in node.tpdos if db.message(c) is not None
                               and "mode" in [s.name for s in db.message(c).signals])
        self.status_msg = db.message(self.status_cob)
        self.modes = {str(v): k for k, v in self.status_msg.get_signal_by_name("mode").choices.items()}
        self.reader = None
        for other in conf.nodes():
            shared = set(other.tpdos) & set(node.rpdos)
            if other is not node and shared:
                self.reader, self.limit_cob = other, shared.pop()
        if self.reader is None:
            pytest.skip(f"no node under test produces an RPDO of {node}")
        self.pos_cob = next(c for c in self.reader.tpdos if db.message(c) is not None and db.message(c).cycle_time
                            and "pos_counts" in [s.name for s in db.message(c).signals])
        sig = db.message(self.pos_cob).get_signal_by_name("pos_counts")
        m = re.search(r"2\*\*(\d+) per revolution", sig.comment or "")
        assert m, f"DBC: pos_counts of 0x{self.pos_cob:03X} does not document counts per revolution"
        self.counts_per_rev = 1 << int(m.group(1))

    # -------------------------------------------------------------- commands
    def value_signal(self, cmd: str):
        code = self.cmds[cmd]
        return next(s for s in self.cmd_msg.signals if s.multiplexer_ids and code in s.multiplexer_ids)

    def encode(self, cmd: str, direction: int = 1, raw: int = 0) -> bytes:
        sig = self.value_signal(cmd)
        dt = self.conf.docs.fixed_device_type(self.cmd_cob)
        return self.cmd_msg.encode({"device_type": dt, "cmd": self.cmds[cmd], "direction": direction,
                                    sig.name: raw}, scaling=False, strict=False)

    def send(self, cmd: str, direction: int = 1, raw: int = 0) -> float:
        t = self.link.now()
        self.link.send(self.cmd_cob, self.encode(cmd, direction, raw))
        return t

    # -------------------------------------------------------------- observations
    def status(self, after: float):
        fr = [f for f in self.link.frames_of(self.status_cob) if f.t >= after]
        return None if not fr else self.status_msg.decode(fr[-1].data, decode_choices=False)

    def mode_after(self, t: float) -> int | None:
        self.link.wait(self.conf.docs.tolerances.command_reaction_s)
        st = self.status(t + 0.011)
        return None if st is None else int(st["mode"])

    def positions(self, t0: float, t1: float):
        msg = self.conf.docs.message(self.pos_cob)
        return [(f.t, int(msg.decode(f.data, decode_choices=False)["pos_counts"]))
                for f in self.link.frames_of(self.pos_cob) if t0 <= f.t <= t1]

    def angle_arcsec(self, counts: int) -> float:
        half = self.counts_per_rev // 2
        c = counts - self.counts_per_rev if counts >= half else counts
        return c * _ARCSEC_PER_TURN / self.counts_per_rev

    def rate(self, window_s: float) -> float:
        """Mean axis rate over the next ``window_s``, ″/s (unwrapped reader positions)."""
        t0 = self.link.now()
        self.link.wait(window_s)
        p = self.positions(t0, self.link.now())
        if len(p) < 2:
            return float("nan")
        total, prev = 0, p[0][1]
        for _, c in p[1:]:
            d = (c - prev) % self.counts_per_rev
            total += d - self.counts_per_rev if d >= self.counts_per_rev // 2 else d
            prev = c
        return total * _ARCSEC_PER_TURN / self.counts_per_rev / (p[-1][0] - p[0][0])

    def refusals(self, t0: float):
        code = self.conf.docs.emcy("COMMAND_REFUSED")
        return [e for e in emcy_frames(self.link.frames_of(0x80 + self.node.node_id), self.node.node_id) if e[0] >= t0 and e[1] == code]

    def malformed(self, t0: float):
        code = self.conf.docs.emcy("MALFORMED_FRAME")
        return [e for e in emcy_frames(self.link.frames_of(0x80 + self.node.node_id), self.node.node_id) if e[0] >= t0 and e[1] == code]

    def stop(self) -> None:
        self.send("STOP", 1, 0)
        self.link.wait(1.0)

    def preset_rate(self, name: str) -> float:
        """The preset's magnitude read by SDO (EDS object 'Preset rates', entry '<NAME> rate'), ″/s."""
        for idx in range(0x2000, 0x3000):
            if idx in self.node.od and hasattr(self.node.od[idx], "subindices"):
                for sub, var in self.node.od[idx].subindices.items():
                    if var.name == f"{name} rate":
                        return self.node.remote.sdo[idx][sub].raw / 1000.0
        raise KeyError(f"{self.node}: the EDS has no '{name} rate' entry")


def _rate_ok(tol, measured, want):
    return abs(measured - want) <= tol.rate_rel * abs(want) + tol.rate_abs_arcsec_s


def test_axis_presets_and_stop(axis_node, conf, check):
    """Each preset (SLEW, SET, GUIDE, FINE, TRACK; direction +1 then SLEW −1): AXIS_STATUS mode
    = the command, the reader's measured rate = direction × the preset read by SDO (0x2001);
    STOP: mode STOP and the axis at rest within 1 s."""
    conf.ensure_operational(axis_node)
    ax = Axis(conf, axis_node)
    conf.ensure_operational(ax.reader)
    tol = conf.docs.tolerances
    try:
        for name, direction in (("SLEW", 1), ("SET", 1), ("GUIDE", 1), ("FINE", 1), ("TRACK", 1),
                                ("SLEW", -1)):
            want = direction * ax.preset_rate(name)
            t = ax.send(name, direction)
            mode = ax.mode_after(t)
            check(f"axis.{name}{direction:+d}.mode", axis_node, f"mode {ax.modes[name]} {name}", mode,
                  mode == ax.modes[name])
            ax.link.wait(tol.settle_s)
            r = ax.rate(tol.rate_window_s)
            check(f"axis.{name}{direction:+d}.rate", axis_node,
                  f"{want:.3f}″/s ± {tol.rate_rel * 100:g} % + {tol.rate_abs_arcsec_s:g}″/s", f"{r:.3f}″/s",
                  _rate_ok(tol, r, want))
        t = ax.send("STOP")
        mode = ax.mode_after(t)
        check("axis.STOP.mode", axis_node, f"mode {ax.modes['STOP']} STOP", mode, mode == ax.modes["STOP"])
        ax.link.wait(1.0)
        r = ax.rate(0.5)
        check("axis.STOP.at_rest", axis_node, f"|rate| <= {tol.rate_abs_arcsec_s:g}″/s 1 s after STOP",
              f"{r:.3f}″/s", abs(r) <= tol.rate_abs_arcsec_s)
    finally:
        ax.stop()


def test_axis_velocity_and_open_loop(axis_node, conf, check):
    """VELOCITY 120″/s: mode VELOCITY, measured rate 120″/s; OPEN_LOOP 5 % duty: mode OPEN_LOOP,
    AXIS_STATUS control effort = the duty (its DBC scaling)."""
    conf.ensure_operational(axis_node)
    ax = Axis(conf, axis_node)
    conf.ensure_operational(ax.reader)       # the rate is measured from its POSITION frames
    tol = conf.docs.tolerances
    try:
        sig = ax.value_signal("VELOCITY")
        raw = int(round(120.0 / sig.scale))
        t = ax.send("VELOCITY", 1, raw)
        mode = ax.mode_after(t)
        check("axis.VELOCITY.mode", axis_node, f"mode {ax.modes['VELOCITY']}", mode, mode == ax.modes["VELOCITY"])
        ax.link.wait(tol.settle_s)
        r = ax.rate(tol.rate_window_s)
        check("axis.VELOCITY.rate", axis_node, "120″/s (value × DBC scale)", f"{r:.3f}″/s", _rate_ok(tol, r, 120.0))
        sig = ax.value_signal("OPEN_LOOP")
        raw = int(round(0.05 / sig.scale))
        t = ax.send("OPEN_LOOP", 1, raw)
        mode = ax.mode_after(t)
        check("axis.OPEN_LOOP.mode", axis_node, f"mode {ax.modes['OPEN_LOOP']}", mode, mode == ax.modes["OPEN_LOOP"])
        st = ax.status(t + 0.011)
        scale = ax.status_msg.get_signal_by_name("control_effort").scale
        effort = None if st is None else float(st["control_effort"])    # decoded with the DBC scale
        check("axis.OPEN_LOOP.effort", axis_node, "control effort 0.05 duty (±1 LSB)", effort,
              effort is not None and abs(effort - 0.05) <= 2 * scale)
    finally:
        ax.stop()


def test_axis_gains(axis_node, conf, check):
    """SET_KP/SET_KI with 1.25 × the gain read from 0x2000: 0x2000 reads the new value; 0 and
    1000 × are refused (EMCY COMMAND_REFUSED, detail low byte = the command) and 0x2000 is
    unchanged (docs/protocol.md: gains are accepted within a band around the tuned gain)."""
    conf.ensure_operational(axis_node)
    ax = Axis(conf, axis_node)
    for name, sub in (("SET_KP", 1), ("SET_KI", 2)):
        sdo = axis_node.remote.sdo[0x2000][sub]
        old = sdo.raw
        try:
            new = int(round(old * 1.25))
            ax.send(name, 1, new)
            ax.link.wait(conf.docs.tolerances.command_reaction_s)
            got = sdo.raw
            check(f"axis.{name}.effect", axis_node, f"0x2000:{sub} = {new}", got, got == new)
            for bad in (0, old * 1000):
                t = ax.send(name, 1, bad)
                ax.link.wait(conf.docs.tolerances.command_reaction_s)
                ref = ax.refusals(t)
                got = sdo.raw
                check(f"axis.{name}.refused[{bad}]", axis_node,
                      f"EMCY COMMAND_REFUSED detail low byte {ax.cmds[name]}; 0x2000:{sub} stays {new}",
                      f"{[hex(e[4]) for e in ref] or 'no EMCY'}; 0x2000:{sub} = {got}",
                      any(e[4] & 0xFF == ax.cmds[name] for e in ref) and got == new)
        finally:
            ax.send(name, 1, old)
            ax.link.wait(conf.docs.tolerances.command_reaction_s)


def _outside(sig):
    """Raw values just outside the DBC range of a command value signal (within its i32 field)."""
    out = []
    lo_raw = int(round(sig.minimum / sig.scale)) if sig.minimum is not None else None
    hi_raw = int(round(sig.maximum / sig.scale)) if sig.maximum is not None else None
    field_lo, field_hi = -(1 << (sig.length - 1)), (1 << (sig.length - 1)) - 1
    if hi_raw is not None and hi_raw < field_hi:
        out.append(hi_raw + 1)
    if lo_raw is not None and lo_raw > field_lo:
        out.append(lo_raw - 1)
    return out


def test_axis_refuses_values_outside_the_dbc(axis_node, conf, check):
    """For every AXIS_COMMAND value signal whose DBC range is narrower than its field, a value
    just outside is refused: EMCY COMMAND_REFUSED (detail low byte = the command), mode unchanged
    (the axis keeps its TRACK). Direction 0 on a preset is malformed (EMCY MALFORMED_FRAME)."""
    conf.ensure_operational(axis_node)
    ax = Axis(conf, axis_node)
    try:
        t = ax.send("TRACK", 1)
        before = ax.mode_after(t)
        tested = 0
        for name, code in ax.cmds.items():
            if name == "STOP":
                continue
            sig = ax.value_signal(name)
            for raw in _outside(sig):
                tested += 1
                t = ax.send(name, 1, raw)
                mode = ax.mode_after(t)
                ref = ax.refusals(t)
                check(f"axis.{name}.outside_range[{raw}]", axis_node,
                      f"DBC {sig.name} [{sig.minimum}, {sig.maximum}]: EMCY COMMAND_REFUSED (detail low byte {code}), "
                      f"mode stays {before}",
                      f"{[hex(e[4]) for e in ref] or 'no EMCY'}; mode {mode}",
                      any(e[4] & 0xFF == code for e in ref) and mode == before)
        check("axis.outside_range.tested", axis_node, "at least one command value with a narrower DBC range",
              tested, tested > 0)
        t = ax.send("SLEW", 0)
        mode = ax.mode_after(t)
        mal = ax.malformed(t)
        check("axis.direction0_preset", axis_node,
              "SLEW with direction 0: EMCY MALFORMED_FRAME (detail = the COB-ID), mode unchanged",
              f"{[hex(e[4]) for e in mal] or 'no EMCY'}; mode {mode}",
              any(e[4] == ax.cmd_cob for e in mal) and mode == before)
    finally:
        ax.stop()


def _here_signed(ax) -> int:
    ax.link.wait(0.05)
    here = ax.positions(ax.link.now() - 0.05, ax.link.now())[-1][1]
    return here - ax.counts_per_rev if here >= ax.counts_per_rev // 2 else here


def test_axis_soft_limit(axis_node, conf, check):
    """A high soft limit written to the reader (EDS 'Soft limits', SDO) 0.5° ahead: moving toward
    it at SET, the axis stops in mode LIMIT_STOP before the limit with EMCY LIMIT_STOP (detail =
    LIMIT flags, high bit); at rest inside the limit the flag clears, the axis returns to STOP
    and the condition is reset (EMCY 0x0000, b3 = LIMIT_STOP's code). A limit 0.5° *behind* the
    axis (the axis past it): a command toward it is refused (COMMAND_REFUSED, the axis does not
    move), a command away is accepted. The limits are restored."""
    conf.ensure_operational(axis_node)
    ax = Axis(conf, axis_node)
    conf.ensure_operational(ax.reader)
    rd = ax.reader
    idx = next(i for i in range(0x2000, 0x3000) if i in rd.od and rd.od[i].name == "Soft limits")
    lo_sdo, hi_sdo = rd.remote.sdo[idx][1], rd.remote.sdo[idx][2]
    lo0, hi0 = lo_sdo.raw, hi_sdo.raw
    code = conf.docs.emcy("LIMIT_STOP")
    fault = conf.docs.fault_code("LIMIT_STOP")
    half_deg = int(1800.0 / _ARCSEC_PER_TURN * ax.counts_per_rev)
    try:
        limit = _here_signed(ax) + half_deg
        hi_sdo.raw = limit
        t0 = ax.send("SET", 1)
        stopped = ax.link.pump_until(
            lambda f: f.cob_id == ax.status_cob and f.t > t0 + 0.011 and
            int(ax.status_msg.decode(f.data, decode_choices=False)["mode"]) == ax.modes["LIMIT_STOP"], 5.0)
        check("limit.stop_mode", axis_node, f"mode {ax.modes['LIMIT_STOP']} LIMIT_STOP when moving toward the limit",
              "reached" if stopped else "not within 5 s", stopped is not None)
        em = [e for e in emcy_frames(ax.link.frames_of(0x80 + axis_node.node_id), axis_node.node_id) if e[0] >= t0 and e[1] == code]
        check("limit.emcy", axis_node, f"EMCY 0x{code:04X} b3 {fault}, detail = LIMIT flags (high bit set)",
              [f"b3 {e[3]} detail 0x{e[4]:X}" for e in em] or "none", any(e[3] == fault and e[4] & 0x2 for e in em))
        ax.link.wait(2.5)
        pos = _here_signed(ax)
        inside = (limit - pos) * _ARCSEC_PER_TURN / ax.counts_per_rev
        check("limit.before_limit", axis_node, f"stopped before the high limit ({limit} counts)",
              f"{pos} counts ({inside:.1f}″ inside)", pos < limit)
        st = ax.status(ax.link.now() - 0.2 - conf.slack)       # the last status frame
        mode = None if st is None else int(st["mode"])
        # docs/boards.md "Soft limits": the flag clears once the axis is at rest and back inside by
        # the hysteresis; at rest closer to the limit than that it is documented to stay
        hyst = LIMIT_HYSTERESIS_ARCSEC
        must_clear = inside > hyst
        check("limit.cleared_to_stop", axis_node,
              f"at rest more than {hyst:g}″ (the reader's hysteresis) inside the limit: the flag clears, "
              f"mode {ax.modes['STOP']} STOP; closer, it stays (mode {ax.modes['LIMIT_STOP']})",
              f"mode {mode}, {inside:.1f}″ inside",
              mode == ax.modes["STOP"] if must_clear else mode in (ax.modes["STOP"], ax.modes["LIMIT_STOP"]))
        # from the SET (t0), not from t1: the flag may clear (and the error reset go out) while the
        # host was still reading the frames before the stop; it cannot precede the stop itself
        em = [e for e in emcy_frames(ax.link.frames_of(0x80 + axis_node.node_id), axis_node.node_id) if e[0] >= t0 and e[1] == 0]
        reset = any(e[3] == fault and e[4] == code for e in em)
        check("limit.error_reset", axis_node,
              f"EMCY 0x0000 b3 {fault} detail 0x{code:04X} once the limit clears (mode STOP), none while it stays",
              f"{[f'b3 {e[3]} detail 0x{e[4]:04X}' for e in em] or 'none'}; mode {mode}",
              reset if mode == ax.modes["STOP"] else (not reset and not must_clear))
        here = _here_signed(ax)
        hi_sdo.raw = here - half_deg                # the axis is now 0.5° past its high limit
        ax.link.wait(0.2)
        t = ax.send("SET", 1)
        ax.link.wait(0.5)
        ref = ax.refusals(t)
        moved = _here_signed(ax) - here
        # "no motion": no more than an axis at rest may drift (the at-rest band of axis.STOP.at_rest,
        # over these 0.5 s); a SET accepted toward the limit would move 300″ in them
        rest = int(conf.docs.tolerances.rate_abs_arcsec_s * 0.5 / _ARCSEC_PER_TURN * ax.counts_per_rev)
        check("limit.toward_refused", axis_node, "past the high limit, SET +1: EMCY COMMAND_REFUSED, no motion "
              f"toward it (at most {rest} counts in 0.5 s: |rate| <= {conf.docs.tolerances.rate_abs_arcsec_s:g}″/s)",
              f"{[hex(e[4]) for e in ref] or 'no EMCY'}; moved {moved} counts",
              any(e[4] & 0xFF == ax.cmds["SET"] for e in ref) and moved <= rest)
        t = ax.send("SET", -1)
        mode = ax.mode_after(t)
        ax.link.wait(0.5)
        moved = _here_signed(ax) - here
        check("limit.away_accepted", axis_node, "SET −1 (away from the limit): mode SET, moving away",
              f"mode {mode}; moved {moved} counts", mode == ax.modes["SET"] and moved < 0)
    finally:
        ax.stop()
        hi_sdo.raw = hi0
        lo_sdo.raw = lo0


def _entry(node, obj_name, entry_name):
    """(index, sub) of the EDS entry ``entry_name`` of object ``obj_name``."""
    for idx in range(0x2000, 0x3000):
        if idx in node.od and node.od[idx].name == obj_name and hasattr(node.od[idx], "subindices"):
            for sub, var in node.od[idx].subindices.items():
                if var.name == entry_name:
                    return idx, sub
    raise KeyError(f"{node}: the EDS has no '{obj_name}: {entry_name}'")


def test_axis_command_log(axis_node, conf, check):
    """EDS 'Command log' (SDO): a TRACK adds one to 'Commands received' and sets 'Last command'
    to its cmd byte; a refused VELOCITY adds one to 'Commands refused' and 'Last refusal' equals
    the detail of its EMCY COMMAND_REFUSED."""
    conf.ensure_operational(axis_node)
    ax = Axis(conf, axis_node)
    sdo = axis_node.remote.sdo
    (i, s_rx), (_, s_last), (_, s_ref), (_, s_lref) = (
        _entry(axis_node, "Command log", n) for n in ("Commands received", "Last command",
                                                      "Commands refused", "Last refusal"))
    try:
        n0, r0 = sdo[i][s_rx].raw, sdo[i][s_ref].raw
        ax.send("TRACK", 1)
        ax.link.wait(conf.docs.tolerances.command_reaction_s)
        n1, last = sdo[i][s_rx].raw, sdo[i][s_last].raw
        check("command_log.received", axis_node, f"'Commands received' +1, 'Last command' = {ax.cmds['TRACK']}",
              f"{n0} -> {n1}, last {last}", n1 == (n0 + 1) % 0x10000 and last == ax.cmds["TRACK"])
        sig = ax.value_signal("VELOCITY")
        t = ax.send("VELOCITY", 1, int(round(sig.maximum / sig.scale)) + 1)
        ax.link.wait(conf.docs.tolerances.command_reaction_s)
        r1, lref = sdo[i][s_ref].raw, sdo[i][s_lref].raw
        ref = ax.refusals(t)
        check("command_log.refused", axis_node, "'Commands refused' +1, 'Last refusal' = the EMCY detail",
              f"{r0} -> {r1}, last 0x{lref:04X}, EMCY {[hex(e[4]) for e in ref]}",
              r1 == r0 + 1 and any(e[4] == lref for e in ref))
    finally:
        ax.stop()


def test_axis_preset_write(axis_node, conf, check):
    """The SET preset is writable by SDO (EDS 'Preset rates: SET rate', rw): 900″/s written, a
    SET command runs at 900″/s (then SET −1 back); a value above the EDS HighLimit is aborted (0x06090031) and
    the preset is unchanged. The preset is restored."""
    import canopen

    conf.ensure_operational(axis_node)
    ax = Axis(conf, axis_node)
    conf.ensure_operational(ax.reader)
    idx, sub = _entry(axis_node, "Preset rates", "SET rate")
    var = axis_node.remote.sdo[idx][sub]
    old = var.raw
    high = axis_node.od[idx][sub].max
    tol = conf.docs.tolerances
    try:
        var.raw = 900_000
        ax.send("SET", 1)
        ax.link.wait(tol.settle_s)
        r = ax.rate(tol.rate_window_s)
        check("preset_write.effect", axis_node, "SET at the written 900″/s", f"{r:.3f}″/s", _rate_ok(tol, r, 900.0))
        ax.send("SET", -1)
        ax.link.wait(tol.settle_s + tol.rate_window_s)
        code = None
        try:
            var.raw = high + 1
        except canopen.SdoAbortedError as exc:
            code = exc.code
        now = var.raw
        check("preset_write.above_high_limit", axis_node, f"write {high + 1} > HighLimit {high}: abort 0x06090031, unchanged",
              f"abort {code and hex(code)}, value {now}", code == 0x06090031 and now == 900_000)
    finally:
        ax.stop()
        var.raw = old
