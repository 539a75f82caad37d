"""Test harness: CANopen devices and a canopen master on the emulated CAN bus, in simulated time.

* :class:`DeviceBoard` — the smallest board around :class:`boards.services.CanopenDevice`: a
  SimBus whose receive interrupt feeds the device (service frames) or records RPDOs, a 10 ms
  timer sending its TPDOs through the device's PDO gate, malformed frames counted as
  ``boards.firmware_base.Board`` does.
* :class:`ParamApp` — a firmware stand-in that owns a few variables and validates writes.
* :class:`PumpedNetwork` — a canopen ``Network`` (the *master*, with canopen ``RemoteNode``s)
  on its own SimBus. canopen's SDO client blocks on a queue after each request; here every
  ``send_message`` advances simulated time (scheduler ``run_until`` in 50 µs steps) until a
  frame arrives for the master or ``pump_limit_us`` passes, so the answer is queued before the
  client looks: no thread, no wall-clock wait.
"""

from __future__ import annotations

import itertools

import can
import canopen

from boards.services import Application, CanopenDevice, ObjectRefused
from boards.services.application import ABORT_MAX_LESS_THAN_MIN
from bus.errors import MalformedFrame
from bus.network import CanNetwork
from bus.scheduler import PRIO_ISR, Scheduler
from bus.simbus import SimBus
from bus.eds import eds_path
from boards.peripherals import Timer

_channels = itertools.count()


def new_network():
    """A scheduler and a CAN network on a unique channel."""
    sch = Scheduler()
    net = CanNetwork(sch, f"canopen-test-{next(_channels)}")
    return sch, net


class ParamApp(Application):
    """Firmware stand-in: owns Kp/Ki/soft limits/offset as plain variables, validates writes."""

    def __init__(self):
        self.reset_application_calls = 0
        self.nmt_changes = []
        self.heartbeat_events = []
        self._power_on()

    def _power_on(self):
        self.values = {(0x2000, 1): 417, (0x2000, 2): 46, (0x2000, 3): 32767, (0x2000, 4): 8192,
                       (0x2100, 1): -70_000_000, (0x2100, 2): 70_000_000, (0x2101, 0): 0,
                       (0x2F00, 1): 0, (0x2F00, 2): 0, (0x2F00, 3): 0, (0x2F00, 4): 0}

    def od_read(self, index, subindex):
        return self.values.get((index, subindex))

    def od_write(self, index, subindex, value):
        key = (index, subindex)
        if key not in self.values or index == 0x2F00:
            raise ObjectRefused(reason="not writable")
        if index == 0x2100:
            lo = value if subindex == 1 else self.values[(0x2100, 1)]
            hi = value if subindex == 2 else self.values[(0x2100, 2)]
            if not lo < hi:
                raise ObjectRefused(ABORT_MAX_LESS_THAN_MIN, "low soft limit must be below high")
        self.values[key] = value

    def nmt_changed(self, old, new):
        self.nmt_changes.append((old, new))

    def reset_application(self):
        self.reset_application_calls += 1
        self._power_on()

    def heartbeat_event(self, node_id, lost):
        self.heartbeat_events.append((node_id, lost))


class DeviceBoard:
    """A board that is nothing but its CANopen services plus periodic TPDOs (8 bytes, byte 0 = device type)."""

    def __init__(self, sch, net, kind, node_id, app=None, tpdo_period_us=10_000):
        self.sch = sch
        self.bus = SimBus(network=net, name=f"{kind}-{node_id}")
        self.app = app if app is not None else ParamApp()
        self.device = CanopenDevice(sch, kind, node_id, self._tx, self.app,
                                    name=f"{kind}-{node_id}")
        self.bus.set_rx_callback(self._on_rx)
        self.malformed = 0
        self.rpdos = []
        self.tpdo_timer = Timer(sch, tpdo_period_us, self._tick, priority=PRIO_ISR,
                                owner=f"{kind}-{node_id}/tick")

    def start(self):
        self.device.boot()
        self.tpdo_timer.start()

    def _tx(self, can_id, data):
        self.bus.send(can.Message(arbitration_id=can_id, data=data, is_extended_id=False))

    def _tick(self, now_us):
        dt = self.device.kind.device_type
        for cob in sorted(self.device.tpdo_ids):
            self.device.transmit_pdo(cob, bytes((dt, 0, 0, 0, 0, 0, 0, 0)))

    def _on_rx(self):
        while (msg := self.bus.recv()) is not None:
            cid = msg.arbitration_id
            if cid not in self.device.accepted_ids:
                continue
            try:
                if not self.device.receive(cid, bytes(msg.data)):
                    if self.device.accept_rpdo(cid):
                        self.rpdos.append((self.sch.now_us, cid, bytes(msg.data)))
            except MalformedFrame:
                self.malformed += 1


class PumpedNetwork(canopen.Network):
    """canopen master network on the emulated bus; sending a frame advances simulated time."""

    def __init__(self, sch: Scheduler, net: CanNetwork, pump_limit_us: int = 20_000,
                 step_us: int = 50):
        super().__init__(bus=None)
        self.sch = sch
        self.simbus = SimBus(network=net, name="canopen-master")
        self.simbus.set_rx_callback(self._on_rx)
        self.pump_limit_us = pump_limit_us
        self.step_us = step_us
        self.received = []          # (t_us, can_id, bytes) of every frame the master saw
        self._rx_count = 0

    def _on_rx(self):
        while (msg := self.simbus.recv()) is not None:
            self.received.append((self.sch.now_us, msg.arbitration_id, bytes(msg.data)))
            self._rx_count += 1
            self.notify(msg.arbitration_id, bytearray(msg.data), msg.timestamp)

    def send_message(self, can_id, data, remote=False):
        self.simbus.send(can.Message(arbitration_id=can_id, data=bytes(data), is_extended_id=False))
        if (can_id & 0x780) == 0x600 or can_id == 0x000:
            self.pump(answer=(can_id & 0x780) == 0x600)

    def pump(self, answer: bool = True):
        """Advance simulated time until a frame for the master arrives (``answer``) or the limit."""
        start, seen = self.sch.now_us, self._rx_count
        while self.sch.now_us - start < self.pump_limit_us:
            self.sch.run_until(self.sch.now_us + self.step_us)
            if answer and any(0x580 <= cid < 0x600 for _, cid, _ in self.received[seen:]):
                return
        return

    def send_periodic(self, *a, **k):
        raise RuntimeError("no wall-clock periodic tasks in the test master")

    def add_remote(self, kind, node_id):
        node = canopen.RemoteNode(node_id, str(eds_path(kind)))
        node.sdo.RESPONSE_TIMEOUT = 0.001    # an unanswered request fails at once (simulated time)
        node.sdo.MAX_RETRIES = 0
        self.add_node(node)
        return node
