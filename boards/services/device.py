"""``CanopenDevice``: the CANopen services of one board, composed as canopen's LocalNode composes them.

Layers (as canopen): network → node → services → object dictionary.

* :class:`boards.services.network.SimNetwork` — canopen ``Network`` without bus/threads;
* :class:`SimLocalNode` — canopen ``LocalNode`` (object dictionary from the kind's EDS, canopen's
  ``get_data``/``set_data`` with read/write callbacks) with its SDO server replaced by
  :class:`boards.services.sdo.SimSdoServer` and its NMT slave by :class:`SimNmtSlave`;
* services: NMT slave, SDO server, heartbeat producer/consumer
  (:mod:`boards.services.heartbeat`), EMCY (:mod:`boards.services.emcy`), the PDO gate.

What of canopen runs in simulated time and what is replaced (docs/canopen.md):

* used as is: ``ObjectDictionary``/``import_od`` (the EDS), ``LocalNode.get_data/set_data``
  (access checks, length check, callbacks, data store), the SDO server's protocol,
  ``NmtSlave`` state bookkeeping and its boot sequence (``send_command``), ``EmcyProducer``;
* replaced: ``start_heartbeat`` (wall-clock ``send_periodic``) → a scheduler timer; NMT reset
  node / reset communication from the bus (canopen stays in INITIALISING, beating ``00``) →
  reset, boot-up, PRE-OPERATIONAL; SDO request robustness (see sdo.py); range checks against
  LowLimit/HighLimit (canopen only logs a warning when *encoding*); the write callback for 0x1017.

Nothing here reads the wall clock, sleeps or starts a thread.
"""

from __future__ import annotations

from typing import Callable, Dict, Optional, Set

from canopen import LocalNode, ObjectDictionary
from canopen import objectdictionary as cod
from canopen.nmt import NMT_STATES, NmtSlave
from canopen.sdo import SdoAbortedError

from boards.services.application import (ABORT_NO_DATA, ABORT_PARAMETER_INCOMPATIBLE,
                                         ABORT_VALUE_INVALID, ABORT_VALUE_TOO_HIGH,
                                         ABORT_VALUE_TOO_LOW, Application)
from boards.services.emcy import EmcyService
from boards.services.heartbeat import HeartbeatConsumer, HeartbeatProducer
from boards.services.network import SimNetwork
from boards.services.pdo import NMT_OPERATIONAL, PdoGate
from boards.services.sdo import SimSdoServer
from bus.eds import load_od
from bus.eds.objects import (KINDS, NMT_CMD_CODE, NMT_COB_ID, heartbeat_cob_id, heartbeat_node,
                             sdo_rx_cob_id, sdo_tx_cob_id)
from bus.errors import MalformedFrame
from bus.scheduler import Scheduler

__all__ = ["CanopenDevice", "SimLocalNode", "SimNmtSlave", "NMT_CS", "STATE_CODE"]

#: NMT command specifiers honoured (CiA 301 §7.2.8.3.1); SLEEP/STANDBY (CiA 320) are not.
NMT_CS = frozenset(NMT_CMD_CODE.values())
#: NMT state names (canopen's) → heartbeat state byte.
STATE_CODE = {name: code for code, name in NMT_STATES.items()}
_INITIALISING, _STOPPED, _PRE_OPERATIONAL = 0, 4, 127
_OPERATIONAL = NMT_OPERATIONAL


class SimNmtSlave(NmtSlave):
    """canopen's NMT slave with bus commands handled fully and no wall-clock heartbeat.

    canopen's ``on_command`` only stores the new state: a remote reset node / reset
    communication leaves the node in INITIALISING for good. Here a reset runs the CiA 301
    sequence (application reset, communication reset, boot-up, PRE-OPERATIONAL) through the
    owning :class:`CanopenDevice`; the heartbeat goes to its scheduler-driven producer.
    """

    def __init__(self, node_id: int, local_node, device: "CanopenDevice") -> None:
        super().__init__(node_id, local_node)
        self._device = device

    def on_command(self, can_id, data, timestamp):
        self._device._nmt_command(bytes(data))

    def start_heartbeat(self, heartbeat_time_ms: int):
        self._heartbeat_time_ms = int(heartbeat_time_ms)
        self._device.heartbeat.set_period_ms(heartbeat_time_ms)

    def stop_heartbeat(self):
        self._device.heartbeat.set_period_ms(0)

    def update_heartbeat(self):
        """Nothing to update: the producer reads the state at every beat."""


class SimLocalNode(LocalNode):
    """canopen ``LocalNode`` whose SDO server and NMT slave run in simulated time."""

    def __init__(self, node_id: int, od: ObjectDictionary, device: "CanopenDevice") -> None:
        super().__init__(node_id, od)
        self.sdo = SimSdoServer(sdo_rx_cob_id(node_id), sdo_tx_cob_id(node_id), self,
                               device._sdo_allowed)
        self.nmt = SimNmtSlave(node_id, self, device)
        self.emcy.cob_id = od[0x1014].default
        # canopen registered its NmtSlave.on_write (it would call send_periodic): replace all
        self._read_callbacks = [device._on_read]
        self._write_callbacks = [device._on_write]


class CanopenDevice:
    """CANopen services (CiA 301) of one board, in simulated time.

    Parameters
    ----------
    scheduler : Scheduler
        The simulation clock (heartbeat timer, heartbeat-consumer deadlines).
    kind : str
        Board kind, a key of :data:`bus.eds.objects.KINDS` (selects the EDS).
    node_id : int
        1..127.
    transmit : callable
        ``transmit(can_id: int, data: bytes)``: queue a frame on the board's CAN controller.
    app : Application, optional
        The firmware side (:class:`boards.services.application.Application`).
    name : str, optional
        Owner name for scheduler errors.
    serial : int, optional
        Serial number (0x1018 sub 4); default the EDS's ``$NODEID`` value.

    Board → services: :meth:`boot` after reset/power-on, :meth:`receive` from the receive
    interrupt for :attr:`accepted_ids`, :meth:`transmit_pdo` for process data,
    :meth:`accept_rpdo` before acting on a received PDO, :attr:`emcy` ``.report()/.clear()``
    for faults, :meth:`power_off`.
    """

    def __init__(self, scheduler: Scheduler, kind: str, node_id: int,
                 transmit: Callable[[int, bytes], None], app: Optional[Application] = None, *,
                 name: Optional[str] = None, serial: Optional[int] = None) -> None:
        if not 1 <= int(node_id) <= 127:
            raise ValueError(f"node_id must be 1..127, got {node_id}")
        self.scheduler = scheduler
        self.kind = KINDS[kind]
        self.node_id = int(node_id)
        self.name = name or f"{kind}-{node_id}"
        self.app = app if app is not None else Application()
        self._transmit = transmit
        self.od = load_od(kind, self.node_id)
        self.network = SimNetwork(self._send)
        self.heartbeat = HeartbeatProducer(scheduler, self.node_id, lambda: self.nmt._state,
                                           self._send, owner=f"{self.name}/heartbeat")
        self.consumer = HeartbeatConsumer(scheduler, self._heartbeat_event,
                                          owner=f"{self.name}/hb-consumer")
        self.node = SimLocalNode(self.node_id, self.od, self)
        self.network[self.node_id] = self.node        # associate: subscribes SDO rx and NMT
        self.emcy = EmcyService(self.node.emcy, self._emcy_allowed)
        self._fixed: Dict[tuple, int] = {}
        if serial is not None:
            self._fixed[(0x1018, 4)] = int(serial)
        self._tpdo_ids: Set[int] = {p.cob_id_for(self.node_id) for p in self.kind.tpdos}
        self._rpdo_ids: Set[int] = {p.cob_id_for(self.node_id) for p in self.kind.rpdos}
        self._consumed: Set[int] = set()
        #: COB-IDs :meth:`receive` hands to the canopen services (NMT, SDO request, the consumed
        #: heartbeats); every other frame (the PDOs) skips the canopen dispatch. Replaced (never
        #: mutated) when the consumed heartbeats change: a receive interrupt may test it first.
        self.service_ids: frozenset = frozenset({NMT_COB_ID, self.node.sdo.rx_cobid})
        self.powered = False
        self._booted_in_reset = False
        self.boots = 0
        #: the PDO gate (:mod:`boards.services.pdo`): reads ``powered`` and the NMT state
        self.pdo = PdoGate(self, self.node.nmt, transmit, self._tpdo_ids, name=self.name)

    # ------------------------------------------------------------------ state
    @property
    def nmt(self) -> SimNmtSlave:
        return self.node.nmt

    @property
    def state(self) -> str:
        """NMT state name: 'INITIALISING', 'PRE-OPERATIONAL', 'OPERATIONAL' or 'STOPPED'."""
        return self.nmt.state

    @property
    def operational(self) -> bool:
        return self.pdo.is_open()

    @property
    def pdos_sent(self) -> int:
        """TPDOs sent (the gate's count)."""
        return self.pdo.pdos_sent

    @property
    def pdos_suppressed(self) -> int:
        """TPDOs dropped outside OPERATIONAL (the gate's count)."""
        return self.pdo.pdos_suppressed

    @property
    def rpdos_ignored(self) -> int:
        """RPDOs received outside OPERATIONAL (the gate's count)."""
        return self.pdo.rpdos_ignored

    @property
    def accepted_ids(self) -> Set[int]:
        """Identifiers the board's acceptance filter must pass to :meth:`receive` or the firmware."""
        return ({NMT_COB_ID, self.node.sdo.rx_cobid} | self._rpdo_ids
                | {heartbeat_cob_id(n) for n in self._consumed})

    @property
    def rpdo_ids(self) -> Set[int]:
        return set(self._rpdo_ids)

    @property
    def tpdo_ids(self) -> Set[int]:
        return set(self._tpdo_ids)

    def _sdo_allowed(self) -> bool:
        return self.powered and self.nmt._state in (_PRE_OPERATIONAL, _OPERATIONAL)

    _emcy_allowed = _sdo_allowed

    # ------------------------------------------------------------------ lifecycle
    def boot(self) -> None:
        """Power-on or processor reset done: reset communication, send boot-up, PRE-OPERATIONAL.

        Uses canopen's own local transition (``NmtSlave.send_command``): INITIALISING sends the
        boot-up frame (0x700 + node, ``00``), INITIALISING → PRE-OPERATIONAL starts the heartbeat
        at the 0x1017 period.
        """
        self.powered = True
        self._reset_communication_objects()
        self.nmt._state = _INITIALISING
        self.nmt.send_command(NMT_CMD_CODE["reset node"])        # state 0 → boot-up frame
        self.nmt.send_command(NMT_CMD_CODE["pre-operational"])   # → 127, heartbeat starts
        self.boots += 1
        self._booted_in_reset = True

    def power_off(self) -> None:
        """Stop the heartbeat and consumer deadlines; nothing is sent or received until :meth:`boot`."""
        self.heartbeat.stop()
        self.consumer.stop()
        self.powered = False
        self.nmt._state = _INITIALISING

    def _reset_communication_objects(self) -> None:
        self.heartbeat.stop()
        for index in [i for i in self.node.data_store if 0x1000 <= i < 0x2000]:
            del self.node.data_store[index]
        self._configure_consumer()

    def _reset_node(self) -> None:
        self._booted_in_reset = False
        self.emcy.reset()
        self.app.reset_application()
        if not self._booted_in_reset:       # the firmware's processor reset may have booted us
            self.boot()

    def _reset_communication(self) -> None:
        self.boot()

    # ------------------------------------------------------------------ receive path
    def receive(self, can_id: int, data: bytes) -> bool:
        """Feed a received frame (call from the receive interrupt).

        Returns
        -------
        bool
            True if a service consumed it (NMT, SDO request, a consumed heartbeat); False if it is
            not a service frame (the firmware handles it, e.g. an RPDO after :meth:`accept_rpdo`).

        Raises
        ------
        bus.errors.MalformedFrame
            For a service frame that does not decode (the board counts it).
        """
        if not self.powered or can_id not in self.service_ids:
            return False
        self.network.notify(can_id, bytes(data), self.scheduler.now_us * 1e-6)
        return True

    def accept_rpdo(self, can_id: int) -> bool:
        """True if a received PDO on ``can_id`` may be acted on now (NMT OPERATIONAL; the
        PDO gate, :meth:`boards.services.pdo.PdoGate.accept_rpdo`)."""
        return self.pdo.accept_rpdo()

    def transmit_pdo(self, cob_id: int, data: bytes) -> bool:
        """Send a TPDO if NMT OPERATIONAL; otherwise drop it (counted). Returns True if sent
        (the PDO gate, :meth:`boards.services.pdo.PdoGate.transmit_pdo`).

        Raises
        ------
        ValueError
            If ``cob_id`` is not one of this node's TPDO COB-IDs (an emulator bug).
        """
        return self.pdo.transmit_pdo(cob_id, data)

    def _send(self, can_id: int, data: bytes) -> None:
        if self.powered:
            self._transmit(can_id, bytes(data))

    def _nmt_command(self, data: bytes) -> None:
        if len(data) != 2:
            raise MalformedFrame("NMT 0x000", "DLC", "2", len(data))
        cs, target = data[0], data[1]
        if target not in (0, self.node_id):
            return
        if cs not in NMT_CS:
            raise MalformedFrame("NMT 0x000", "command specifier",
                                 "0x01, 0x02, 0x80, 0x81 or 0x82", f"0x{cs:02X}")
        if cs == NMT_CMD_CODE["reset node"]:
            self._reset_node()
            return
        if cs == NMT_CMD_CODE["reset communication"]:
            self._reset_communication()
            return
        old = self.nmt.state
        self.nmt._state = {NMT_CMD_CODE["start"]: _OPERATIONAL, NMT_CMD_CODE["stop"]: _STOPPED,
                           NMT_CMD_CODE["pre-operational"]: _PRE_OPERATIONAL}[cs]
        if self.nmt.state != old:
            self.app.nmt_changed(old, self.nmt.state)

    # ------------------------------------------------------------------ heartbeat consumer
    def _configure_consumer(self) -> None:
        for n in self._consumed:
            self.network.unsubscribe(heartbeat_cob_id(n), self._on_heartbeat)
        times = self._consumer_times()
        self._consumed = set(times)
        self.service_ids = frozenset({NMT_COB_ID, self.node.sdo.rx_cobid}
                                     | {heartbeat_cob_id(n) for n in self._consumed})
        for n in self._consumed:
            self.network.subscribe(heartbeat_cob_id(n), self._on_heartbeat)
        self.consumer.configure(times)

    def _consumer_times(self) -> Dict[int, int]:
        times: Dict[int, int] = {}
        if 0x1016 not in self.od:
            return times
        for sub in range(1, self.od[0x1016][0].default + 1):
            raw = self._stored(0x1016, sub)
            node, t = (raw >> 16) & 0xFF, raw & 0xFFFF
            if node and t:
                times[node] = t
        return times

    def _on_heartbeat(self, can_id, data, timestamp) -> None:
        if len(data) != 1:
            raise MalformedFrame(f"heartbeat 0x{can_id:03X}", "DLC", "1", len(data))
        self.consumer.on_heartbeat(heartbeat_node(can_id))

    def _heartbeat_event(self, node_id: int, lost: bool) -> None:
        if lost:
            self.emcy.report("HEARTBEAT_LOST", node_id)
        else:
            self.emcy.clear("HEARTBEAT_LOST")
        self.app.heartbeat_event(node_id, lost)

    # ------------------------------------------------------------------ object access
    def _on_read(self, index: int, subindex: int, od) -> Optional[object]:
        if index == 0x1001:
            return self.emcy.error_register
        if index == 0x1003:
            if subindex == 0:
                return len(self.emcy.history)
            if subindex > len(self.emcy.history):
                raise SdoAbortedError(ABORT_NO_DATA)
            return self.emcy.history[subindex - 1]
        if (index, subindex) in self._fixed:
            return self._fixed[(index, subindex)]
        if index >= 0x2000:
            return self.app.od_read(index, subindex)
        return None

    def _on_write(self, index: int, subindex: int, od, data: bytes) -> None:
        value = od.decode_raw(bytes(data))
        if od.data_type in cod.NUMBER_TYPES:
            if od.min is not None and value < od.min:
                raise SdoAbortedError(ABORT_VALUE_TOO_LOW)
            if od.max is not None and value > od.max:
                raise SdoAbortedError(ABORT_VALUE_TOO_HIGH)
        if index == 0x1003:
            if value != 0:
                raise SdoAbortedError(ABORT_VALUE_INVALID)
            self.emcy.clear_history()
        elif index == 0x1017:
            self.heartbeat.set_period_ms(value if self.powered else 0)
        elif index == 0x1016:
            node = (value >> 16) & 0xFF
            if value >> 24 or (value & 0xFFFF and not 1 <= node <= 127):
                raise SdoAbortedError(ABORT_VALUE_INVALID)
            monitored = []
            for sub in range(1, self.od[0x1016][0].default + 1):
                raw = value if sub == subindex else self._stored(0x1016, sub)
                if raw & 0xFFFF and raw >> 16:
                    monitored.append(raw >> 16)
            if len(monitored) != len(set(monitored)):
                raise SdoAbortedError(ABORT_PARAMETER_INCOMPATIBLE)   # one node monitored twice
            self.node.data_store.setdefault(0x1016, {})[subindex] = bytes(data)
            self._configure_consumer()
        elif index >= 0x2000:
            self.app.od_write(index, subindex, value)

    def _stored(self, index: int, subindex: int) -> int:
        return self.od[index][subindex].decode_raw(self.node.get_data(index, subindex))
