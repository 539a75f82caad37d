"""The host's CANopen master: canopen ``RemoteNode`` SDO clients on the host's own bus, in simulated time.

canopen's SDO client sends a request and then waits on a queue for the answer. Here
:class:`HostCanopenNetwork.send_message` puts the request on the host's python-can bus and then
advances time (the host's ``advance``: the scheduler, or on SocketCAN the real-time pacer) in
small steps until an SDO answer from that node has arrived (through
``HostClient.canopen_notify``) or :attr:`HostCanopenNetwork.PUMP_LIMIT_US` has passed; the
client then finds the answer already queued. No thread and no wall-clock wait in simulated
time; on a real bus the pacer's steps are wall-clock time.

What the host reads (report.json ``boards.<name>.identity`` / ``.parameters``):

* identity: 0x1018 (vendor id, product code, revision, serial number), 0x1008 device name,
  0x100A software version;
* parameters: every manufacturer object (0x2000–0x2EFF) with a range in the node's EDS — the
  gains, effort limit, counter fraction, preset rates, soft limits, encoder offset, focus travel,
  step rate and LVDT reference (docs/canopen.md) — as read back over SDO. An object the node
  refuses to read (SDO abort) is reported with its abort code instead of a value.
"""

from __future__ import annotations

from typing import Callable

import can
import canopen
from canopen.sdo.exceptions import SdoAbortedError, SdoCommunicationError

from bus import protocol as P
from bus.eds import eds_path
from bus.eds.objects import KINDS

__all__ = ["HostCanopenNetwork", "IDENTITY_OBJECTS", "read_identity", "read_parameters"]

#: (report key, index, subindex) of the identity the host reads from every node.
IDENTITY_OBJECTS = (("vendor_id", 0x1018, 1), ("product_code", 0x1018, 2),
                    ("revision", 0x1018, 3), ("serial_number", 0x1018, 4),
                    ("device_name", 0x1008, 0), ("software_version", 0x100A, 0))


class HostCanopenNetwork(canopen.Network):
    """canopen master network whose frames go out on the host's python-can bus.

    Parameters
    ----------
    bus : can.BusABC
        The host's bus (the HostClient's).
    now_us : callable
        ``now_us() -> int``: current simulated time.
    advance : callable
        ``advance(t_us)``: run time forward to ``t_us`` (scheduler ``run_until`` or the pacer's).
    """

    PUMP_LIMIT_US = 20_000   #: longest wait for one SDO answer [µs] (assumed: 80× the 244 µs measured)
    STEP_US = 100            #: time step while waiting [µs]

    def __init__(self, bus: can.BusABC, now_us: Callable[[], int], advance: Callable[[int], None]) -> None:
        super().__init__(bus=None)
        self._bus = bus
        self._now_us = now_us
        self._advance = advance
        self._answers = 0
        self.sdo_requests = 0

    def notify(self, can_id: int, data, timestamp) -> None:
        if P.FC_SDO_TX < can_id < P.FC_SDO_RX:
            self._answers += 1
        super().notify(can_id, bytearray(data), timestamp)

    def send_message(self, can_id: int, data, remote: bool = False) -> None:
        self._bus.send(can.Message(arbitration_id=can_id, data=bytes(data), is_extended_id=False))
        if P.FC_SDO_RX < can_id < P.FC_SDO_RX + 0x80:
            self.sdo_requests += 1
            seen, start = self._answers, self._now_us()
            while self._answers == seen and self._now_us() - start < self.PUMP_LIMIT_US:
                self._advance(self._now_us() + self.STEP_US)

    def send_periodic(self, *args, **kwargs):
        raise RuntimeError("the host's canopen network runs no wall-clock periodic task")

    def add_board(self, kind: str, node_id: int) -> canopen.RemoteNode:
        """A ``RemoteNode`` for board ``node_id`` with the EDS of ``kind``; an unanswered request
        fails after :attr:`PUMP_LIMIT_US` of pumping (no retry, no wall-clock timeout)."""
        node = canopen.RemoteNode(node_id, str(eds_path(kind)))
        node.sdo.RESPONSE_TIMEOUT = 0.001
        node.sdo.MAX_RETRIES = 0
        self.add_node(node)
        return node


def read_identity(node: canopen.RemoteNode) -> dict:
    """Identity of ``node`` read by SDO (keys of :data:`IDENTITY_OBJECTS`).

    Raises
    ------
    canopen.SdoAbortedError, canopen.SdoCommunicationError
        The node aborts or does not answer.
    """
    out = {}
    for key, index, sub in IDENTITY_OBJECTS:
        obj = node.sdo[index]
        out[key] = (obj[sub] if sub else obj).raw
    return out


def read_parameters(node: canopen.RemoteNode) -> dict:
    """Every manufacturer object with a range in the node's EDS, read by SDO.

    Returns
    -------
    dict
        ``{"0x2000:1": {"name", "value", "unit", "access", "range"}}``; ``value`` None and
        ``abort`` = the SDO abort code when the node refuses the read.
    """
    units = {(o.index, e.subindex): e.unit for k in KINDS.values() for o in k.objects()
             for e in o.entries}
    out = {}
    for index in sorted(i for i in node.object_dictionary.indices if 0x2000 <= i < 0x2F00):
        obj = node.object_dictionary[index]
        entries = [obj] if isinstance(obj, canopen.objectdictionary.Variable) else [
            obj[s] for s in sorted(obj.subindices) if s > 0]
        for var in entries:
            if var.min is None and var.max is None:
                continue
            key = f"0x{index:04X}:{var.subindex}"
            name = var.name if var is obj else f"{obj.name}: {var.name}"
            row = {"name": name, "unit": units.get((index, var.subindex), ""), "access": var.access_type,
                   "range": [var.min, var.max]}
            try:
                sdo = node.sdo[index] if var is obj else node.sdo[index][var.subindex]
                row["value"] = sdo.raw
            except SdoAbortedError as exc:
                row["value"], row["abort"] = None, f"0x{exc.code:08X}"
            out[key] = row
    return out


__all__ += ["SdoAbortedError", "SdoCommunicationError"]
