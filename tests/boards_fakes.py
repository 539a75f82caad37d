"""Test doubles for the boards tests: a python-can bus with a receive hook and a toy axis plant.

Not the real plant (boards tests must not depend on plant/): a first-order rate model
``dω/dt = (k·(duty_a − duty_b) − ω)/τ`` integrated in 100 µs steps, plus the QEI count.
"""

from __future__ import annotations

from collections import deque

import can

from bus.scheduler import PRIO_PLANT


def FakeBus(rx_interrupt: bool = True):
    """A fake bus with (``SimBus``-like) or without (plain python-can) a receive hook."""
    return InterruptFakeBus() if rx_interrupt else PlainFakeBus()


class PlainFakeBus(can.BusABC):
    """In-memory bus: ``inject`` delivers a frame (and fires the rx callback), ``sent`` records."""

    def __init__(self):
        super().__init__(channel="fake")
        self._is_shutdown = True     # nothing to release; silences the __del__ warning
        self.sent = []
        self._rx = deque()
        self._cb = None

    def send(self, msg, timeout=None):
        self.sent.append(msg)

    def _recv_internal(self, timeout):
        if self._rx:
            return self._rx.popleft(), False
        return None, False

    def inject(self, arbitration_id, data, **kw):
        self._rx.append(can.Message(arbitration_id=arbitration_id, data=bytes(data),
                                    is_extended_id=kw.pop("is_extended_id", False), **kw))
        if self._cb is not None:
            self._cb()

    def frames(self, arbitration_id):
        return [m for m in self.sent if m.arbitration_id == arbitration_id]

    def shutdown(self):
        super().shutdown()


class InterruptFakeBus(PlainFakeBus):
    """Fake bus with ``set_rx_callback`` (the receive interrupt of ``bus.simbus.SimBus``)."""

    def set_rx_callback(self, fn):
        self._cb = fn


class ToyAxis:
    """First-order axis-rate model driven by two duties; QEI counts from the integrated angle."""

    def __init__(self, scheduler, k_arcsec_s_per_duty=19_550.0, tau_s=0.09,
                 arcsec_per_count=1_296_000 / 112_896_000, step_us=100):
        self.s = scheduler
        self.k, self.tau = k_arcsec_s_per_duty, tau_s
        self.arcsec_per_count = arcsec_per_count
        self.omega = 0.0          # arcsec/s
        self.angle = 0.0          # arcsec
        self.duties = (0.0, 0.0)
        self.step_us = step_us
        scheduler.call_every(step_us, self._step, priority=PRIO_PLANT, owner="toy-plant")

    def set_duties(self, a, b):
        self.duties = (a, b)

    def _step(self, now_us):
        dt = self.step_us * 1e-6
        u = self.duties[0] - self.duties[1]
        self.omega += dt * (self.k * u - self.omega) / self.tau
        self.angle += self.omega * dt

    def qei_counts(self):
        return int(self.angle // self.arcsec_per_count)


def nmt_start(*boards):
    """Put each board in NMT OPERATIONAL, as the host's NMT start (``01 00`` on 0x000) does,
    through the board's receive handler. Boards boot PRE-OPERATIONAL and act on process data
    (commands, LIMIT, STOP_ALL) and send their periodic frames only when OPERATIONAL."""
    for b in boards:
        b._on_rx(can.Message(arbitration_id=0x000, data=bytes((0x01, 0x00)), is_extended_id=False))


def install_leaky_pdo_gate(monkeypatch) -> None:
    """Build every board created next with a broken PDO gate: a firmware defect whose TPDOs leave
    the node in every NMT state (while powered). An interpreted subclass of the compiled
    ``PdoGate``, installed where ``CanopenDevice`` builds its gate (replacing a method of
    ``CanopenDevice`` would not reach the compiled firmware, which calls the gate directly)."""
    from boards.services import device as D
    from boards.services.pdo import PdoGate

    class LeakyGate(PdoGate):
        def transmit_pdo(self, cob_id, data):
            if self.device.powered:
                self.transmit(cob_id, bytes(data))
            return True

    monkeypatch.setattr(D, "PdoGate", LeakyGate)


def install_axis_firmware(monkeypatch, cls) -> None:
    """Build the axis boards of the next network (``host.network.build_network``) with firmware
    class ``cls`` (a deliberately broken subclass of ``AxisController``).

    A subclass in the registry, not a patched method: the firmware is compiled (mypyc,
    bus/_native.py), and compiled code calls its own methods directly, so a method replaced on
    the class would not be seen by the firmware that calls it."""
    import dataclasses

    import host.network as N
    from boards import registry as R

    boards = dict(N.BOARDS)
    for name, (spec, inst) in R.BOARDS.items():
        if spec.kind == "axis_controller":
            boards[name] = (dataclasses.replace(spec, firmware=cls), inst)
    monkeypatch.setattr(N, "BOARDS", boards)
