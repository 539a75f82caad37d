"""A passive host node: decodes and logs what is on the bus, commands nothing.

``schmidt-fil serve`` leaves the commanding to a host program outside the emulator (the
operator's own software on ``vcan0``/``can0``, or another Python object on the in-process bus).
Our host node then only listens, like a CAN analyser: :class:`BusMonitor` is a
:class:`host.client.HostClient` (same decoding of status, position, focus, heartbeat, fault and
limit frames, same ``status.log``/``errors.log`` lines) that also decodes the frames *the
external host* sends — ``AXIS_COMMAND``, ``FOCUS_COMMAND``, ``STOP_ALL``, ``NMT`` — into
``commands.log`` and into the setpoint each command means, and counts every frame by
identifier. It refuses to command (:meth:`BusMonitor.command_axis` and friends raise).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import can

from bus import protocol as P
from boards.registry import NODE_NAMES
from host.client import AXIS_NODES, HostClient

__all__ = ["BusMonitor", "PassiveHostError"]

_AXIS_OF_NODE = {node: axis for axis, node in AXIS_NODES.items()}


class PassiveHostError(RuntimeError):
    """Something asked the passive monitor to command the boards."""


@dataclass
class BusMonitor(HostClient):
    """Host node that listens only (see the module docstring).

    Parameters are those of :class:`host.client.HostClient`. Attributes added:

    frames_by_id : dict
        Frames received per identifier (every frame but the ones this node sent itself).
    commands_seen : dict
        External commands seen per kind (``"AXIS_COMMAND TRACK"``, ``"NMT START"``, ...).
    setpoints : dict
        ``{"ra": ..., "dec": ...}``: the rate [arcsec/s] the last external command to each axis
        means (firmware preset rates for the preset modes; ``nan`` for OPEN_LOOP, whose duty
        has no rate; 0 after STOP, STOP_ALL, or an NMT command that takes a node out of
        OPERATIONAL: stop, pre-operational, reset).
    limit_frames : int
        ``LIMIT`` frames seen (reader → axis controller).
    on_frame : callable(can.Message), optional
        Called with every received frame before it is decoded (``candump.log`` on SocketCAN).
    """

    on_frame: Callable[[can.Message], None] | None = None
    #: a listener on the CAN bus itself, not the PC behind the USB gateway (the gateway is left
    #: unpowered: docs/usb-gateway.md)
    THROUGH_GATEWAY = False

    def __post_init__(self) -> None:
        super().__post_init__()
        self.frames_by_id: dict[int, int] = {}
        self.commands_seen: dict[str, int] = {}
        self.limit_frames = 0
        self._handlers[P.AxisCommandFrame] = self._on_AxisCommandFrame
        self._handlers[P.FocusCommandFrame] = self._on_FocusCommandFrame
        self._handlers[P.StopAll] = self._on_StopAll
        self._handlers[P.Nmt] = self._on_Nmt

    def _handle(self, msg: can.Message) -> None:
        cob = msg.arbitration_id
        self.frames_by_id[cob] = self.frames_by_id.get(cob, 0) + 1
        if self.on_frame is not None:
            self.on_frame(msg)
        super()._handle(msg)

    # -- the external host's frames ----------------------------------------------------------
    def _seen(self, now: int, target: str, kind: str, name: str, detail: str) -> None:
        key = f"{kind} {name}"
        self.commands_seen[key] = self.commands_seen.get(key, 0) + 1
        if self.logs:
            self.logs.command(now, target, name, detail)

    def _on_AxisCommandFrame(self, cob_id: int, f, now: int) -> None:
        node = P.node_of(cob_id)
        axis = _AXIS_OF_NODE[node]
        cmd = P.AxisCommand(f.cmd)
        sign = f.direction if f.direction in (1, -1) else 1   # the firmware's reading of 0
        if cmd == P.AxisCommand.STOP:
            self.setpoints[axis] = 0.0
        elif cmd == P.AxisCommand.VELOCITY:
            self.setpoints[axis] = sign * f.value / 1000.0
        elif cmd == P.AxisCommand.OPEN_LOOP:
            self.setpoints[axis] = math.nan
        elif cmd not in (P.AxisCommand.SET_KP, P.AxisCommand.SET_KI):
            rate = self.preset_rates_arcsec_s.get((cmd.name.lower(), axis))
            self.setpoints[axis] = math.nan if rate is None else sign * rate
        self._seen(now, NODE_NAMES[node], "AXIS_COMMAND", cmd.name, f"direction={f.direction:+d} value={f.value}")

    def _on_FocusCommandFrame(self, cob_id: int, f, now: int) -> None:
        self._seen(now, "focus", "FOCUS_COMMAND", P.FocusCommand(f.cmd).name, f"halfsteps={f.value}")

    def _stopped(self, target_node: int) -> str:
        for axis, node in AXIS_NODES.items():
            if target_node in (0, node):
                self.setpoints[axis] = 0.0
        return "all" if target_node == 0 else NODE_NAMES.get(target_node, f"node-{target_node}")

    def _on_StopAll(self, cob_id: int, f, now: int) -> None:
        self._seen(now, self._stopped(f.target_node), "STOP_ALL", "STOP_ALL", "")

    def _on_Nmt(self, cob_id: int, f, now: int) -> None:
        cmd = P.NmtCommand(f.cmd)
        if cmd == P.NmtCommand.START:
            target = "all" if f.target_node == 0 else NODE_NAMES.get(f.target_node, f"node-{f.target_node}")
        else:
            target = self._stopped(f.target_node)
        self._seen(now, target, "NMT", cmd.name, "")

    def _on_Limit(self, cob_id: int, f, now: int) -> None:
        self.limit_frames += 1
        super()._on_Limit(cob_id, f, now)

    # -- a passive node does not command -----------------------------------------------------
    def power_on(self):
        """Refused: the external host does the health check."""
        raise PassiveHostError("the bus monitor is passive: the external host does the health check")

    def command_axis(self, *args, **kwargs) -> float:
        """Refused: the external host commands the axes."""
        raise PassiveHostError("the bus monitor is passive: the external host commands the axes")

    def command_focus_move_to(self, halfsteps: int) -> None:
        """Refused: the external host commands the focus."""
        raise PassiveHostError("the bus monitor is passive: the external host commands the focus")
