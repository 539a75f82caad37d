"""Peripheral models of the PIC/dsPIC boards (Renode style).

Each class models only the registers and behaviour the schmidt-fil firmware uses, holds its
mutable runtime state apart from its configuration, and has ``reset()`` restoring the power-on
state. Peripherals meet the outside world through **ports**: plain callables handed in by
``host/network.py`` (architecture.md, "boards/"). Nothing here imports ``plant/``, reads the
wall clock, sleeps or starts threads; time comes from the :class:`bus.scheduler.Scheduler`.

Sources: dsPIC30F3011 / dsPIC30F family reference manual (MCPWM, QEI, 10-bit ADC modules),
MCP2515 data sheet (two receive buffers RXB0/RXB1), PIC18F4480 ECAN (legacy mode 0: two receive
buffers), the paper §3.3-§3.4 (T. S. Kumar and R. N. Banavar, Opt. Eng. 52(8) 081607, 2013).
"""

from __future__ import annotations

import math
from math import floor as _floor, isfinite as _isfinite
from collections import deque
from typing import Any, Callable, ClassVar, Deque, Dict, Final, Optional

import can

from bus.network import RxFrame
from bus.scheduler import PRIO_BACKGROUND, PRIO_ISR, Event, Scheduler

__all__ = [
    "Timer",
    "Pwm",
    "Qei",
    "Adc",
    "CanController",
    "Uart",
    "StepDir",
    "Dac",
    "AbsoluteEncoderInput",
    "DigitalInput",
    "CharacterDisplay",
    "FCY_HZ",
    "PWM_FREQUENCY_HZ",
]

#: dsPIC30F3011 instruction clock assumed for the duty resolution, Hz (30 MIPS, the device's
#: maximum; the paper does not state the clock).
FCY_HZ: Final = 30_000_000
#: PWM frequency assumed, Hz (above audibility; the paper does not state it).
PWM_FREQUENCY_HZ: Final = 20_000


class Timer:
    """Periodic hardware timer whose interrupt runs ``isr(now_us)``.

    Parameters
    ----------
    scheduler : Scheduler
        The simulation's single clock.
    period_us : int
        Interrupt period, µs (5000 for the axis controller's 5 ms sampling, paper §3.3).
    isr : callable
        ``isr(now_us: int)``, the interrupt service routine.
    priority : int, optional
        Scheduler priority, default ``PRIO_ISR``.
    owner : str, optional
        Owner name shown in :class:`bus.errors.SimulationError`.
    """

    def __init__(self, scheduler: Scheduler, period_us: int, isr: Callable[[int], None], *,
                 priority: int = PRIO_ISR, owner: str = "timer") -> None:
        if int(period_us) <= 0:
            raise ValueError(f"period_us must be > 0, got {period_us}")
        self.scheduler = scheduler
        self.period_us = int(period_us)
        self.isr = isr
        self.priority = priority
        self.owner = owner
        self._event: Optional[Event] = None
        self._first_us = 0
        self._ticks_before = 0       # interrupts of earlier runs (since the last reset)

    @property
    def ticks(self) -> int:
        """Interrupts since the last :meth:`reset` (counted from the scheduler's event: the ISR
        is scheduled directly, with no counting wrapper per interrupt)."""
        ev = self._event
        if ev is None:
            return self._ticks_before
        # the scheduler sets ev.t_us to the next run before calling the ISR, so inside the ISR
        # of the k-th interrupt this is k, as a counter incremented before the ISR would be
        period_us = ev.period_us
        assert period_us is not None          # a periodic event
        return self._ticks_before + (ev.t_us - self._first_us) // period_us

    @property
    def running(self) -> bool:
        """True while the timer is enabled (TON bit)."""
        return self._event is not None

    def start(self, start_us: Optional[int] = None) -> None:
        """Enable the timer; the first interrupt fires one period after ``start_us`` (default now)."""
        self.stop()
        t0 = self.scheduler.now_us if start_us is None else int(start_us)
        self._first_us = t0 + self.period_us
        self._event = self.scheduler.call_every(self.period_us, self.isr,
                                                start_us=self._first_us,
                                                priority=self.priority, owner=self.owner)

    def stop(self) -> None:
        """Disable the timer (pending interrupt cancelled)."""
        if self._event is not None:
            self._ticks_before = self.ticks
            self.scheduler.cancel(self._event)
            self._event = None

    def reset(self) -> None:
        """Power-on state: stopped, tick count zero."""
        self.stop()
        self._ticks_before = 0


class Pwm:
    """Two-channel motor-control PWM (dsPIC30F MCPWM) with the duty-register quantisation.

    Edge-aligned at ``frequency_hz`` from ``fcy_hz``: PTPER = fcy/f − 1 (1499 at 30 MIPS,
    20 kHz); the duty registers PDCx count half instruction cycles, so a duty has
    ``2·(PTPER+1)`` steps (3000, i.e. a quantum of 3.3e-4 = 0.033 %).

    Parameters
    ----------
    channels : int
        Number of channels (2: motor A = positive direction, motor B = negative, paper §3.3).
    on_change : callable, optional
        Port ``on_change(duty_a, duty_b)`` called with the quantised duties (0..1) whenever a
        duty register is written (the plant's ``set_duties``).
    frequency_hz, fcy_hz : int, optional
        PWM frequency and instruction clock, Hz (both assumed, see module constants).
    """

    def __init__(self, channels: int = 2, on_change: Optional[Callable[[float, float], None]] = None,
                 *, frequency_hz: int = PWM_FREQUENCY_HZ, fcy_hz: int = FCY_HZ) -> None:
        if channels != 2:
            raise ValueError("the axis boards use exactly 2 PWM channels")
        self.channels = channels
        self.on_change = on_change
        self.ptper = fcy_hz // frequency_hz - 1
        self.steps = 2 * (self.ptper + 1)
        self.enabled = True
        self.duty_register = [0, 0]

    @property
    def duty_quantum(self) -> float:
        """Smallest duty step (fraction of the period)."""
        return 1.0 / self.steps

    @property
    def duties(self) -> tuple:
        """Current quantised duties ``(duty_a, duty_b)``, 0..1 (0 while disabled)."""
        if not self.enabled:
            return (0.0, 0.0)
        return (self.duty_register[0] / self.steps, self.duty_register[1] / self.steps)

    def set_duties(self, duty_a: float, duty_b: float) -> None:
        """Write both duty registers (values clipped to 0..1 and rounded to the register step)."""
        steps = self.steps
        a = 0.0 if not _isfinite(duty_a) else min(1.0, max(0.0, float(duty_a)))
        b = 0.0 if not _isfinite(duty_b) else min(1.0, max(0.0, float(duty_b)))
        ra, rb = int(round(a * steps)), int(round(b * steps))
        self.duty_register = [ra, rb]
        if self.on_change is not None:          # _notify() inlined (called every 5 ms tick)
            if self.enabled:
                self.on_change(ra / steps, rb / steps)
            else:
                self.on_change(0.0, 0.0)

    def disable(self) -> None:
        """Override both outputs low (PWM outputs disabled)."""
        self.enabled = False
        self._notify()

    def enable(self) -> None:
        """Re-enable the outputs with the current duty registers."""
        self.enabled = True
        self._notify()

    def _notify(self) -> None:
        if self.on_change is not None:
            self.on_change(*self.duties)

    def reset(self) -> None:
        """Power-on state: duties zero, outputs enabled."""
        self.enabled = True
        self.duty_register = [0, 0]
        self._notify()


class Qei:
    """Quadrature encoder interface: 16-bit POSCNT plus the firmware's 32-bit software extension.

    The port returns the encoder's cumulative signed count; the hardware register only holds it
    modulo 2**16 (MAXCNT = 0xFFFF). :meth:`read_delta` is what the firmware does each tick: read
    POSCNT, take the signed 16-bit difference from the last read, and add it to a software
    extension. Correct while fewer than 32768 counts pass between two reads (a 2°/s slew gives
    ≈3140 counts per 5 ms tick with 4.608e6 counts/rev × 24.5, paper §2.2/§3.2).

    Parameters
    ----------
    read_counts : callable
        Port returning the cumulative encoder count (int, signed, counts).
    """

    MODULUS: ClassVar[int] = 1 << 16

    def __init__(self, read_counts: Callable[[], int]) -> None:
        self.read_counts = read_counts
        #: MODULUS as an instance attribute: the compiled ISR reads it natively (a class
        #: attribute read through ``self`` is a generic lookup)
        self._modulus: int = self.MODULUS
        self.extended = 0
        self._last_poscnt = 0
        self._offset = 0

    @property
    def poscnt(self) -> int:
        """The 16-bit POSCNT register, 0..65535."""
        return (int(self.read_counts()) - self._offset) % self._modulus

    def read_delta(self) -> int:
        """Read POSCNT, update the 32-bit extension and return the signed count change."""
        m = self._modulus
        p = (int(self.read_counts()) - self._offset) % m          # POSCNT (self.poscnt)
        delta = (p - self._last_poscnt) % m
        if delta >= m >> 1:
            delta -= m
        self._last_poscnt = p
        self.extended = ((self.extended + delta + (1 << 31)) % (1 << 32)) - (1 << 31)
        return delta

    def reset(self) -> None:
        """Power-on: POSCNT cleared (the port's present count becomes zero), extension zero."""
        self._offset = int(self.read_counts())
        self._last_poscnt = 0
        self.extended = 0


class Adc:
    """Successive-approximation ADC (10-bit on dsPIC30F3011 and PIC18F4431/4480).

    counts = floor(v / vref · 2**bits), clipped to 0 .. 2**bits − 1. Sampling is synchronous:
    the firmware triggers :meth:`sample` inside its ISR (on the dsPIC the conversion is started by
    the PWM special-event trigger at the falling edge where the motor current peaks, §3.3; the
    shunt voltage reaching the port is taken to be that filtered peak).

    Parameters
    ----------
    channels : dict
        Name → port returning volts.
    bits : int
        Resolution (10).
    vref_v : float
        Reference voltage, V (5.0).
    """

    def __init__(self, channels: Dict[str, Callable[[], float]], bits: int = 10,
                 vref_v: float = 5.0) -> None:
        self.channels = dict(channels)
        self.bits = int(bits)
        self.vref_v = float(vref_v)
        self.full_scale = (1 << self.bits) - 1
        self.last: Dict[str, int] = {name: 0 for name in self.channels}

    @property
    def lsb_v(self) -> float:
        """One count, V."""
        return self.vref_v / (1 << self.bits)

    def to_counts(self, volts: float) -> int:
        """Convert a voltage to counts as the converter does."""
        if not math.isfinite(volts):
            return self.full_scale if volts > 0 else 0
        c = int(math.floor(volts / self.vref_v * (1 << self.bits)))
        return min(self.full_scale, max(0, c))

    def to_volts(self, counts: int) -> float:
        """Mid-point voltage of a count, V (counts·lsb)."""
        return counts * self.lsb_v

    def sample(self, name: str) -> int:
        """Convert channel ``name`` now; returns counts (also kept in ``last``)."""
        port = self.channels.get(name)
        if port is None:
            c = 0
        else:                                   # to_counts() inlined (two channels every tick)
            volts = float(port())
            if not _isfinite(volts):
                c = self.full_scale if volts > 0 else 0
            else:
                c = int(_floor(volts / self.vref_v * (1 << self.bits)))
                c = min(self.full_scale, max(0, c))
        self.last[name] = c
        return c

    def reset(self) -> None:
        """Power-on: result buffers zero."""
        self.last = {name: 0 for name in self.channels}


#: python-can bus classes whose filters act before the receive queue (SimBus: on delivery;
#: SocketCAN: kernel filters), so ``set_filters`` is a true hardware acceptance filter there.
FILTER_BEFORE_QUEUE_BUSES: Final = ("SimBus", "SocketcanBus")


#: Hardware transmit buffers of the boards' CAN controllers: TXB0..TXB2 on the MCP2515 (DS21801
#: §3.1) and on the PIC18F4480's ECAN module in mode 0 (DS39637 §24.2).
TX_BUFFERS: Final = 3


def tx_priority(arbitration_id: int) -> int:
    """TXP<1:0> the firmware writes with a frame it loads into a transmit buffer.

    Assumed (the paper does not say; the datasheets leave it to the firmware): the top bits of
    the identifier, so that the controller's own choice among its three buffers (highest TXP
    first, then the highest buffer number, DS21801 §3.2) follows the bus's arbitration order as
    far as four levels allow: 3 for 0x000–0x0FF (NMT, EMCY), 2 for 0x100–0x1FF (TPDO1: the status
    and POSITION frames, STOP_ALL), 1 for 0x200–0x2FF (TPDO2: AXIS_AUX, LIMIT; the commands),
    0 from 0x300 (SDO, heartbeat). Frames of one level go by buffer number (the datasheet rule).
    """
    return 3 - min(3, arbitration_id >> 8)


class CanController:
    """CAN controller (MCP2515 or the PIC18F4480's ECAN in mode 0) on a python-can bus.

    Receive path: acceptance filter (``accept(arbitration_id)``, the hardware masks/filters) →
    ``rx_buffers`` hardware receive buffers (2 on both chips; a frame arriving with both full is
    lost and counted in ``rx_overflows``) → the firmware's receive handler ``on_rx(msg)``.
    If the bus offers ``set_rx_callback`` (``bus.simbus.SimBus``) the receive interrupt drains the
    bus at each delivery; otherwise the firmware polls with :meth:`poll` (at most ``rx_buffers``
    frames survive between two polls, as with a polled MCP2515).

    Transmit: :meth:`send` never raises; a ``can.CanError`` is counted in ``tx_errors``. On a
    bus with ``set_tx_buffers`` (``schmidt-sim``) the node transmits through :data:`TX_BUFFERS`
    hardware buffers chosen by TXP (:func:`tx_priority`; ``bus.network.TxBuffers``: the
    datasheets' transmit priority, the firmware's FIFO in front); other buses keep their own
    order.

    Parameters
    ----------
    bus : can.BusABC
        Any python-can bus (``schmidt-sim``, ``virtual``, ``socketcan`` ...).
    rx_buffers : int
        Hardware receive buffers (2).
    tx_buffers : int
        Transmit buffers the firmware loads (:data:`TX_BUFFERS`; 1 = one at a time, which keeps
        the order frames were sent in: a FIFO).
    """

    def __init__(self, bus: Any, rx_buffers: int = 2, tx_buffers: int = TX_BUFFERS) -> None:
        self.bus = bus
        self.rx_buffers = int(rx_buffers)
        self.accept: Callable[[int], bool] = lambda arbitration_id: True
        self.on_rx: Optional[Callable[[can.Message], None]] = None
        #: the receive handler as ``on_frame(arbitration_id, data)``: on a bus that queues
        #: :class:`~bus.network.RxFrame` objects (``schmidt-sim``), the receive interrupt calls
        #: this instead of ``on_rx`` and no ``can.Message`` is built (frames there are always
        #: standard data frames of 0..8 bytes). Unset: ``on_rx`` gets Messages on every bus.
        self.on_frame: Optional[Callable[[int, bytes], None]] = None
        self._hw: Deque[can.Message] = deque()
        #: transmit buffers the firmware uses (1: one at a time, so frames leave in send order)
        self.tx_buffers = int(tx_buffers)
        set_tx_buffers = getattr(bus, "set_tx_buffers", None)
        if set_tx_buffers is not None and self.tx_buffers > 1:
            set_tx_buffers(self.tx_buffers, tx_priority)
        self.rx_overflows = 0
        self.rx_frames = 0
        self.tx_frames = 0
        self.tx_errors = 0
        self.interrupt_enabled = False
        self.has_rx_interrupt = hasattr(bus, "set_rx_callback")
        self._send_frame = getattr(bus, "send_frame", None)
        self._drain = getattr(bus, "drain_rx", None)
        self._drain_frames = getattr(bus, "drain_rx_frames", None)

    def enable_rx_interrupt(self) -> bool:
        """Hook the receive interrupt if the bus supports it; returns True if it does."""
        if self.has_rx_interrupt:
            self.bus.set_rx_callback(self._rx_interrupt)
            self.interrupt_enabled = True
        return self.interrupt_enabled

    def disable_rx_interrupt(self) -> None:
        """Unhook the receive interrupt."""
        if self.interrupt_enabled:
            self.bus.set_rx_callback(None)
            self.interrupt_enabled = False

    def set_acceptance(self, arbitration_ids) -> None:
        """Program the hardware acceptance filters (MCP2515 masks/filters, ECAN mode 0).

        Installed as python-can filters (``bus.set_filters``), so the bus drops other frames
        before they reach the controller: on ``schmidt-sim`` they raise no interrupt, on
        ``socketcan`` the kernel filters them. ``accept`` stays as a second, software check.
        """
        ids = sorted({int(i) for i in arbitration_ids})
        if type(self.bus).__name__ not in FILTER_BEFORE_QUEUE_BUSES:
            # python-can applies filters of other interfaces (e.g. ``virtual``) inside ``recv``,
            # and ``recv(timeout=0)`` returns None at the first filtered-out frame: a polled
            # controller would then drain one foreign frame per poll and fall behind. There the
            # software ``accept`` check does the filtering instead.
            return
        self.bus.set_filters([{"can_id": i, "can_mask": 0x7FF, "extended": False} for i in ids])

    def _fill_buffers(self) -> None:
        recv, accept, hw, n = self.bus.recv, self.accept, self._hw, self.rx_buffers
        drain = self._drain
        if drain is not None:                 # schmidt-sim: every pending frame at once
            msgs = drain()
        else:
            msgs = iter(lambda: recv(0), None)
        for msg in msgs:
            if not accept(msg.arbitration_id):
                continue
            if len(hw) >= n:
                self.rx_overflows += 1      # RXnOVR: the frame is lost
                continue
            hw.append(msg)

    def _service(self) -> None:
        while self._hw:
            msg = self._hw.popleft()
            self.rx_frames += 1
            if self.on_rx is not None:
                self.on_rx(msg)

    def _rx_interrupt(self, *args) -> None:
        # Hardware fills its buffers, then the ISR empties them one by one.
        hw, n, accept = self._hw, self.rx_buffers, self.accept
        on_frame = self.on_frame
        if on_frame is not None and self._drain_frames is not None and not hw:
            # schmidt-sim (the hot path): _fill_buffers + _service on RxFrame objects, the same
            # steps in the same order, no can.Message per frame. The accept/overrun loop repeats
            # _fill_buffers' on purpose: shared through one helper taking either frame type, its
            # untyped attribute access cost 1.3 % of the full network's instructions (session 9,
            # 130.6 -> 132.3 M per simulated second); keep the two loops alike.
            frames: list[RxFrame] = self._drain_frames()
            kept: list[RxFrame] = []
            for fr in frames:
                if not accept(fr.arbitration_id):
                    continue
                if len(kept) >= n:
                    self.rx_overflows += 1      # RXnOVR: the frame is lost
                    continue
                kept.append(fr)
            for fr in kept:
                self.rx_frames += 1
                on_frame(fr.arbitration_id, fr.data)
            return
        self._fill_buffers()
        self._service()

    def poll(self) -> None:
        """Polled receive, on a bus without a receive interrupt (python-can ``virtual``,
        SocketCAN): every accepted frame waiting is serviced, as the receive interrupt would have
        serviced it on arrival.

        The two hardware buffers and their overrun (RXnOVR) are modelled only where frames
        arrive at their wire times (the ``schmidt-sim`` bus, with its interrupt). On a polled bus
        frames wait in python-can's queue (or the kernel's socket buffer) between polls, so a
        two-buffer limit applied there would lose frames because of the poll period, which the
        real board, interrupt-driven, would not (found: a TRACK command lost on ``virtual``)."""
        recv, accept = self.bus.recv, self.accept
        drain = self._drain
        msgs = drain() if drain is not None else iter(lambda: recv(0), None)
        for msg in msgs:
            if not accept(msg.arbitration_id):
                continue
            self.rx_frames += 1
            if self.on_rx is not None:
                self.on_rx(msg)

    def send(self, arbitration_id: int, data: bytes) -> bool:
        """Transmit a standard-identifier data frame; returns False (and counts) on a bus error.

        On a bus with ``send_frame(id, data)`` (``schmidt-sim``) no ``can.Message`` is built.
        """
        try:
            send_frame = self._send_frame
            if send_frame is not None:
                send_frame(arbitration_id, data)
            else:
                self.bus.send(can.Message(arbitration_id=arbitration_id, data=data, is_extended_id=False))
        except can.CanError:
            self.tx_errors += 1
            return False
        self.tx_frames += 1
        return True

    # Error-counter registers (MCP2515 TEC/REC/EFLG; PIC18 ECAN TXERRCNT/RXERRCNT/COMSTAT).
    # Read from the bus's fault-confinement model when it has one (``schmidt-sim``); a bus
    # without one (python-can virtual, socketcan here) reads as an error-active node at 0/0.
    @property
    def tec(self) -> int:
        """Transmit error counter (TEC register), 0..255 (saturates at 255 when bus-off)."""
        es = getattr(self.bus, "error_state", None)
        return min(es.tec, 255) if es is not None else 0

    @property
    def rec(self) -> int:
        """Receive error counter (REC register), 0..255."""
        es = getattr(self.bus, "error_state", None)
        return min(es.rec, 255) if es is not None else 0

    @property
    def error_state(self) -> str:
        """``"error-active"``, ``"error-passive"`` or ``"bus-off"`` (EFLG TXBO/TXEP/RXEP bits)."""
        es = getattr(self.bus, "error_state", None)
        return es.state if es is not None else "error-active"

    def request_recovery(self) -> None:
        """Leave bus-off (the firmware's recovery request; no-op on a bus without the model)."""
        fn = getattr(self.bus, "request_recovery", None)
        if fn is not None:
            fn()

    def reset(self) -> None:
        """Power-on: buffers empty, counters zero, interrupt unhooked (firmware re-enables it)."""
        self.disable_rx_interrupt()
        self._hw.clear()
        self.rx_overflows = 0
        self.rx_frames = 0
        self.tx_frames = 0
        self.tx_errors = 0


class Uart:
    """Asynchronous serial port of a board (the RS232 link of §3.4), on a pyserial-like port.

    The firmware writes bytes; the UART hands them to ``port``, any object with the pyserial
    ``write()`` API: a :class:`bus.serial_link.SerialEnd` in the emulator (byte timing in
    simulated time), or a real ``serial.Serial`` / ``serial.serial_for_url("loop://",
    timeout=0)``. The firmware code is the same for all of them. Bytes fed with :meth:`feed`
    wait in a receive FIFO of ``rx_fifo`` bytes (4 on the PIC/dsPIC UARTs; overflow counted,
    byte lost).

    Parameters
    ----------
    port : object, optional
        Transmit side: has ``write(bytes) -> int``; optionally ``out_waiting`` (bytes not yet
        sent) and ``reset_output_buffer()``.
    on_tx : callable, optional
        Alternative to ``port``: ``on_tx(data)`` called for every write (tests).
    rx_fifo : int
        Receive FIFO depth, bytes (4).

    Attributes
    ----------
    tx_bytes, tx_writes : int
        Bytes and write calls since reset.
    tx_late : int
        Writes started while the previous write was still waiting to be sent (``out_waiting``
        > 0): the line is too slow for the data rate. Counted, the data still queued.
    tx_log : deque
        The last 8 writes (debugging; bounded so long runs do not grow).
    """

    def __init__(self, port=None, on_tx: Optional[Callable[[bytes], None]] = None,
                 rx_fifo: int = 4) -> None:
        self.port = port
        self.on_tx = on_tx
        self.rx_fifo = int(rx_fifo)
        self._rx: Deque[int] = deque()
        self._has_out_waiting = port is not None and hasattr(port, "out_waiting")
        self.rx_overruns = 0
        self.tx_bytes = 0
        self.tx_writes = 0
        self.tx_late = 0
        self.tx_log: Deque[bytes] = deque(maxlen=8)

    def write(self, data: bytes) -> int:
        """Transmit bytes; returns the number handed to the port."""
        data = bytes(data)
        self.tx_writes += 1
        self.tx_bytes += len(data)
        self.tx_log.append(data)
        n = len(data)
        if self.port is not None:
            if self._has_out_waiting and self.port.out_waiting:
                self.tx_late += 1
            n = self.port.write(data)
        if self.on_tx is not None:
            self.on_tx(data)
        return n

    def feed(self, data: bytes) -> None:
        """Bytes arriving on RX."""
        for b in bytes(data):
            if len(self._rx) >= self.rx_fifo:
                self.rx_overruns += 1
            else:
                self._rx.append(b)

    def read(self) -> bytes:
        """Empty the receive FIFO."""
        out = bytes(self._rx)
        self._rx.clear()
        return out

    def reset(self) -> None:
        """Power-on: FIFO empty, counters and log cleared; a transmission in progress is
        aborted (``reset_output_buffer`` of the port: bytes not yet on the wire are lost)."""
        self._rx.clear()
        self.rx_overruns = 0
        self.tx_bytes = self.tx_writes = self.tx_late = 0
        self.tx_log.clear()
        if self.port is not None and hasattr(self.port, "reset_output_buffer"):
            self.port.reset_output_buffer()


class StepDir:
    """Step/direction output to the bipolar stepper's dual H-bridge (half-step mode, §3.3).

    Parameters
    ----------
    on_step : callable
        Port ``on_step(direction)`` called with +1 or −1 for every half step issued.
    on_power : callable, optional
        Port ``on_power(state)`` with state ``"on"`` (windings driven), ``"hold"`` (motor power
        off, windings shorted through the free-wheeling diodes: regenerative holding, §3.3/§5.2)
        or ``"free"`` (control power off).
    half_step : bool
        Half-step mode (True, 0.9° per step on the KM062, §3.2).
    """

    POWER_STATES: ClassVar[tuple] = ("on", "hold", "free")

    def __init__(self, on_step: Callable[[int], None],
                 on_power: Optional[Callable[[str], None]] = None, half_step: bool = True) -> None:
        self.on_step = on_step
        self.on_power = on_power
        self.half_step = bool(half_step)
        self.direction = 1
        self.steps_issued = 0        # signed count of steps output since reset
        self.power = "on"

    def set_direction(self, direction: int) -> None:
        """Set the DIR line (+1 / −1)."""
        self.direction = 1 if direction >= 0 else -1

    def step(self) -> None:
        """One STEP pulse in the current direction (ignored unless power is on)."""
        if self.power != "on":
            return
        self.steps_issued += self.direction
        self.on_step(self.direction)

    def set_power(self, state: str) -> None:
        """Switch the bridge power state (``"on"``, ``"hold"``, ``"free"``)."""
        if state not in self.POWER_STATES:
            raise ValueError(f"power state must be one of {self.POWER_STATES}, got {state!r}")
        if state != self.power:
            self.power = state
            if self.on_power is not None:
                self.on_power(state)

    def reset(self) -> None:
        """Power-on: direction +, step count zero, bridge on."""
        self.direction = 1
        self.steps_issued = 0
        self.set_power("on")


# -- issue 12: synchronous serial (SSI) read of an absolute encoder -----------------------------
class SsiMaster:
    """Synchronous serial interface (SSI) master reading a single-turn absolute encoder word.

    The PIC's synchronous serial port clocks ``bits`` data bits out of the encoder (MSB first,
    binary). Only what the firmware uses is modelled: one read returns the word; no clock-level
    timing, no Gray code, no parity (the Gurley A25S's interface options are not given in the
    paper; assumed binary SSI).

    Parameters
    ----------
    read_word : callable
        Port returning the encoder's word, 0 .. 2**bits − 1.
    bits : int
        Word width (17 for the A25S, paper §3.2).

    Raises
    ------
    ValueError
        From :meth:`read` never: a word outside the width is masked, as the shift register would.
    """

    def __init__(self, read_word: Callable[[], int], bits: int) -> None:
        self.read_word = read_word
        self.bits = int(bits)
        self._mask = (1 << self.bits) - 1
        self.reads = 0

    def read(self) -> int:
        """One SSI transfer: the encoder word."""
        self.reads += 1
        return int(self.read_word()) & self._mask

    def reset(self) -> None:
        """Power-on: the read counter cleared."""
        self.reads = 0


__all__.append("SsiMaster")
# -- end issue 12 ---------------------------------------------------------------------------------


# Background polling priority used by boards whose bus has no receive interrupt.
POLL_PRIORITY: Final = PRIO_BACKGROUND


from boards.endat import EnDatMaster  # noqa: E402  (defined with its protocol)

__all__.append("EnDatMaster")


# -- issue 12, room nodes (dome, weather station, display unit) -----------------------------------


class Dac:
    """Digital-to-analog converter giving a drive's bipolar speed reference (e.g. ±10 V into a
    variable-frequency drive), normalised to −1 .. 1 of full scale.

    The written value is quantised to ``bits`` (two's complement: ±(2**(bits−1) − 1) steps) and
    handed to the port at once.

    Parameters
    ----------
    on_change : callable(fraction)
        Port: the analog output, −1 .. 1 of full scale.
    bits : int
        Resolution (12 assumed, plant/parameters.yaml ``dome.dac_bits``).
    """

    def __init__(self, on_change: Callable[[float], None], bits: int = 12) -> None:
        self.on_change = on_change
        self.bits = int(bits)
        self.steps = (1 << (self.bits - 1)) - 1
        self.code = 0

    @property
    def quantum(self) -> float:
        """One step of the output, fraction of full scale."""
        return 1.0 / self.steps

    def write(self, fraction: float) -> float:
        """Set the output (clipped to ±1, quantised); returns the fraction written."""
        f = max(-1.0, min(1.0, float(fraction)))
        self.code = int(round(f * self.steps))
        out = self.code / self.steps
        self.on_change(out)
        return out

    def reset(self) -> None:
        """Power-on: output zero."""
        self.code = 0
        self.on_change(0.0)


class AbsoluteEncoderInput:
    """Synchronous-serial (SSI) absolute encoder input: one read returns the encoder word.

    Parameters
    ----------
    read_word : callable() -> int
        Port: the encoder's position word, 0 .. counts_per_rev − 1.
    counts_per_rev : int
        Counts per revolution (the word is reduced modulo it).
    """

    def __init__(self, read_word: Callable[[], int], counts_per_rev: int) -> None:
        self.read_word = read_word
        self.counts_per_rev = int(counts_per_rev)
        self.reads = 0

    def read(self) -> int:
        """One read: the word, counts."""
        self.reads += 1
        return int(self.read_word()) % self.counts_per_rev

    def reset(self) -> None:
        self.reads = 0


class DigitalInput:
    """One digital input pin (e.g. a rain sensor's relay contact); read synchronously."""

    def __init__(self, read_level: Callable[[], bool]) -> None:
        self.read_level = read_level

    def read(self) -> bool:
        return bool(self.read_level())

    def reset(self) -> None:
        """Nothing to reset (an input)."""


class CharacterDisplay:
    """The display unit's 7-segment / character-LCD driver: :meth:`show` writes one whole
    screen (a line of text) to the port, as the firmware's refresh would drive the segments.

    Parameters
    ----------
    on_show : callable(text) or None
        Port receiving every screen written (the host logs it: ``display.log``).
    """

    def __init__(self, on_show: Optional[Callable[[str], None]] = None) -> None:
        self.on_show = on_show
        self.text = ""
        self.writes = 0

    def show(self, text: str) -> None:
        self.text = text
        self.writes += 1
        if self.on_show is not None:
            self.on_show(text)

    def reset(self) -> None:
        """Power-on: blank."""
        self.text = ""
