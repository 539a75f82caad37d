"""Point-to-point RS232 links in simulated time (paper §3.4: boards to PC via an 8-port hub).

A :class:`SerialLink` joins two :class:`SerialEnd` objects. Bytes written at one end arrive at
the other one by one, each taking ``bits_per_byte`` bit times (8N1 = 10 bits) at ``baud``;
writes queue behind bytes still being shifted out, so a 25-sample packet every 250 ms takes
its real wire time. Byte *i* of a burst starting at ``t0_us`` is readable from
``t0_us + ceil((i + 1) * bits_per_byte * 1e6 / baud)``.

:class:`SerialEnd` has the subset of the pyserial ``Serial`` API a board or the host needs
(``write``, ``read``, ``read_until``, ``in_waiting``, ``out_waiting``, ``reset_input_buffer``,
``reset_output_buffer``, ``close``, ``is_open``, ``baudrate``), with ``timeout = 0`` semantics:
reads return what has arrived *by the current simulated time* and never block. Code written
against that subset runs unchanged on ``serial.serial_for_url("loop://", timeout=0)`` or a
real port.

Not emulated: parity, framing and overrun errors, break, modem lines (RTS/CTS/DTR/DSR), flow
control, receive FIFO limits, line noise, the hub's own buffering and the PC's USB latency.
No per-byte events are scheduled: arrival is computed on demand, and an optional rx callback
runs once per write burst when its last byte arrives (like a UART idle-line interrupt).
"""

from __future__ import annotations

from collections import deque
from typing import Callable

from bus.errors import BusError
from bus.scheduler import PRIO_ISR, Scheduler

__all__ = ["SerialLink", "SerialEnd"]


class _Direction:
    """Bytes in flight one way: bursts of (t0_us, data, consumed)."""

    __slots__ = ("bursts", "free_us")

    def __init__(self) -> None:
        self.bursts: deque = deque()   # [t0_us, data, consumed]
        self.free_us = 0               # when the transmitter has shifted out everything queued


class SerialEnd:
    """One end of a :class:`SerialLink`, pyserial-like (non-blocking, simulated time)."""

    def __init__(self, link: "SerialLink", tx: _Direction, rx: _Direction, name: str) -> None:
        self._link = link
        self._tx = tx
        self._rx = rx
        self.name = name
        self.port = name
        self.timeout = 0
        self.is_open = True
        self._rx_callback: Callable[[], object] | None = None
        self.bytes_written = 0
        self.bytes_read = 0

    @property
    def baudrate(self) -> int:
        """Line rate, baud (shared by both ends)."""
        return self._link.baud

    # -- writing ----------------------------------------------------------------------------
    def write(self, data) -> int:
        """Queue ``data`` for transmission; returns the number of bytes queued (never blocks)."""
        if not self.is_open:
            raise BusError(f"serial {self.name}: write on a closed port")
        data = bytes(data)
        if not data:
            return 0
        link = self._link
        now = link.scheduler.now_us
        t0 = max(now, self._tx.free_us)
        self._tx.bursts.append([t0, data, 0])
        self._tx.free_us = t0 + link.transfer_time_us(len(data))
        self.bytes_written += len(data)
        peer = link.b if self is link.a else link.a
        if peer._rx_callback is not None:
            link.scheduler.call_at(self._tx.free_us, peer._fire, PRIO_ISR, owner=f"serial:{peer.name}")
        return len(data)

    @property
    def out_waiting(self) -> int:
        """Bytes written by this end and not yet fully received by the other end."""
        return self._link._pending(self._tx) - self._link._arrived(self._tx)

    def flush(self) -> None:
        """No-op (pyserial waits for transmission; in simulated time nothing can pass)."""

    def reset_output_buffer(self) -> None:
        """Discard bytes not yet on the wire (the byte being shifted out is lost too)."""
        now = self._link.scheduler.now_us
        arrived = self._link._arrived(self._tx)
        kept = self._link._take(self._tx, arrived, peek=True)
        self._tx.bursts.clear()
        if kept:
            self._tx.bursts.append([now - self._link.transfer_time_us(len(kept)), kept, 0])
        self._tx.free_us = now

    # -- reading ----------------------------------------------------------------------------
    @property
    def in_waiting(self) -> int:
        """Bytes arrived by now and not yet read."""
        return self._link._arrived(self._rx)

    def read(self, size: int = 1) -> bytes:
        """Return up to ``size`` bytes that have arrived (possibly ``b""``); never blocks."""
        if not self.is_open:
            raise BusError(f"serial {self.name}: read on a closed port")
        n = min(size, self._link._arrived(self._rx))
        data = self._link._take(self._rx, n)
        self.bytes_read += len(data)
        return data

    def read_all(self) -> bytes:
        """Return every byte arrived so far."""
        return self.read(self.in_waiting)

    def read_until(self, expected: bytes = b"\n", size: int | None = None) -> bytes:
        """pyserial semantics with timeout 0: up to and including ``expected``, else all arrived
        bytes (up to ``size``)."""
        avail = self._link._take(self._rx, self._link._arrived(self._rx), peek=True)
        idx = avail.find(expected)
        n = len(avail) if idx < 0 else idx + len(expected)
        if size is not None:
            n = min(n, size)
        return self.read(n)

    def reset_input_buffer(self) -> None:
        """Discard bytes already arrived."""
        self._link._take(self._rx, self._link._arrived(self._rx))

    def set_rx_callback(self, fn: Callable[[], object] | None) -> None:
        """``fn()`` runs (``PRIO_ISR``) when the last byte of each burst written by the peer
        arrives; set it before the peer writes."""
        self._rx_callback = fn

    def _fire(self, now_us: int) -> None:
        if self._rx_callback is not None and self.is_open:
            self._rx_callback()

    def close(self) -> None:
        """Close this end (further reads and writes raise BusError)."""
        self.is_open = False

    def __repr__(self) -> str:
        return f"<SerialEnd {self.name} {self.baudrate} baud>"


class SerialLink:
    """A full-duplex point-to-point serial line between ends ``a`` and ``b``.

    Parameters
    ----------
    scheduler : Scheduler
        The simulation clock.
    baud : int
        Line rate, bit/s (default 115 200).
    bits_per_byte : int
        Bits on the wire per byte (default 10: start + 8 data + stop, 8N1).
    name : str
        Port name prefix; the ends are ``f"{name}.a"`` and ``f"{name}.b"``.
    """

    def __init__(self, scheduler: Scheduler, baud: int = 115_200, bits_per_byte: int = 10,
                 name: str = "serial") -> None:
        if baud <= 0 or bits_per_byte <= 0:
            raise BusError(f"serial {name}: baud and bits_per_byte must be > 0")
        self.scheduler = scheduler
        self.baud = baud
        self.bits_per_byte = bits_per_byte
        self._bit_us_num = bits_per_byte * 1_000_000   # µs per byte = num / baud
        ab, ba = _Direction(), _Direction()
        self.a = SerialEnd(self, ab, ba, f"{name}.a")
        self.b = SerialEnd(self, ba, ab, f"{name}.b")

    def transfer_time_us(self, nbytes: int) -> int:
        """Wire time of ``nbytes`` back-to-back bytes, µs (rounded up)."""
        return -((-nbytes * self._bit_us_num) // self.baud)

    # -- internals: arrival computed from the clock -----------------------------------------
    def _arrived(self, d: _Direction) -> int:
        now = self.scheduler.now_us
        total = 0
        for t0, data, consumed in d.bursts:
            if t0 > now:
                break
            n = min(len(data), (now - t0) * self.baud // self._bit_us_num)
            total += n - consumed
            if n < len(data):
                break
        return total

    def _pending(self, d: _Direction) -> int:
        return sum(len(b[1]) - b[2] for b in d.bursts)

    def _take(self, d: _Direction, n: int, peek: bool = False) -> bytes:
        out = []
        for burst in list(d.bursts):
            if n <= 0:
                break
            t0, data, consumed = burst
            k = min(n, len(data) - consumed)
            out.append(data[consumed:consumed + k])
            n -= k
            if not peek:
                burst[2] = consumed + k
                if burst[2] == len(data):
                    d.bursts.popleft()
        return b"".join(out)
