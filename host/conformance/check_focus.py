"""Focus commands (every node with a FOCUS_COMMAND RPDO in the DBC): MOVE_TO, STEP, STOP, HOLD,
FREE and the refusal of targets outside the travel read by SDO (EDS 'Focus drive: Travel')."""

from __future__ import annotations

import pytest

from host.conformance.check_malformed import emcy_frames

pytestmark = pytest.mark.motion


class Focus:
    def __init__(self, conf, node):
        self.conf, self.node, self.link, db = conf, node, conf.link, conf.docs
        self.cmd_cob = next(c for c in node.rpdos if db.message(c) is not None
                            and db.message(c).name.startswith("FOCUS_COMMAND"))
        self.cmd_msg = db.message(self.cmd_cob)
        self.cmds = {str(v): k for k, v in self.cmd_msg.get_signal_by_name("cmd").choices.items()}
        self.status_cob = next(c for c in node.tpdos if db.message(c) is not None
                               and "pos_halfsteps" in [s.name for s in db.message(c).signals])
        self.status_msg = db.message(self.status_cob)
        self.period_s = self.status_msg.cycle_time / 1000.0

    def send(self, cmd: str, value: int = 0) -> float:
        t = self.link.now()
        dt = self.conf.docs.fixed_device_type(self.cmd_cob)
        self.link.send(self.cmd_cob, self.cmd_msg.encode({"device_type": dt, "cmd": self.cmds[cmd],
                                                          "value": value}, scaling=False, strict=False))
        return t

    def status_after(self, wait_s: float) -> dict:
        """The last FOCUS_STATUS after waiting ``wait_s`` plus two status periods."""
        t = self.link.now()
        self.link.wait(wait_s + 2 * self.period_s)
        fr = [f for f in self.link.frames_of(self.status_cob) if f.t > t + wait_s]
        return self.status_msg.decode(fr[-1].data, decode_choices=False) if fr else {}

    def travel(self) -> int:
        for idx in range(0x2000, 0x3000):
            if idx in self.node.od and hasattr(self.node.od[idx], "subindices"):
                for sub, var in self.node.od[idx].subindices.items():
                    if var.name == "Travel":
                        return self.node.remote.sdo[idx][sub].raw
        raise KeyError(f"{self.node}: the EDS has no 'Travel' entry")


def test_focus_moves_and_refuses(focus_node, conf, check):
    """MOVE_TO +100, STEP +50, STEP −150: pos_halfsteps = the target and 'moving' clear once there
    (2 s allowed); MOVE_TO travel + 1 and STEP past the travel: EMCY COMMAND_REFUSED (detail low
    byte = the command), position unchanged; HOLD sets 'holding', FREE sets 'power_off'."""
    conf.ensure_operational(focus_node)
    fo = Focus(conf, focus_node)
    travel = fo.travel()
    code = conf.docs.emcy("COMMAND_REFUSED")
    pos = None
    for cmd, value, want in (("MOVE_TO", 100, 100), ("STEP", 50, 150), ("STEP", -150, 0)):
        fo.send(cmd, value)
        st = fo.status_after(2.0)
        pos = st.get("pos_halfsteps")
        check(f"focus.{cmd}[{value}]", focus_node, f"pos_halfsteps {want}, not moving",
              f"pos {pos}, moving {st.get('moving')}", pos == want and st.get("moving") == 0)
    for cmd, value in (("MOVE_TO", travel + 1), ("MOVE_TO", -travel - 1), ("STEP", travel + 1)):
        t = fo.send(cmd, value)
        st = fo.status_after(0.5)
        ref = [e for e in emcy_frames(fo.link.frames_of(0x80 + focus_node.node_id), focus_node.node_id) if e[0] >= t and e[1] == code]
        check(f"focus.refused[{cmd} {value}]", focus_node,
              f"travel ±{travel} (0x2200 Travel): EMCY COMMAND_REFUSED detail low byte {fo.cmds[cmd]}, position stays {pos}",
              f"{[hex(e[4]) for e in ref] or 'no EMCY'}; pos {st.get('pos_halfsteps')}",
              any(e[4] & 0xFF == fo.cmds[cmd] for e in ref) and st.get("pos_halfsteps") == pos)
    fo.send("HOLD")
    st = fo.status_after(0.0)
    check("focus.HOLD", focus_node, "flag holding set", st.get("holding"), st.get("holding") == 1)
    fo.send("FREE")
    st = fo.status_after(0.0)
    check("focus.FREE", focus_node, "flag power_off set", st.get("power_off"), st.get("power_off") == 1)
    fo.send("MOVE_TO", 0)
    st = fo.status_after(0.5)
    check("focus.power_on_again", focus_node, "MOVE_TO after FREE: power_off and holding clear",
          f"power_off {st.get('power_off')} holding {st.get('holding')}",
          st.get("power_off") == 0 and st.get("holding") == 0)
