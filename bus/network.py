"""The emulated shared CAN bus: CAN 2.0A bit timing, arbitration and delivery in simulated time.

A :class:`CanNetwork` is one physical bus (one ``channel`` name). :class:`bus.simbus.SimBus`
objects attach to it; ``SimBus.send`` hands the frame to :meth:`CanNetwork.submit`.

Model
-----
* Each attached bus has a TX queue kept in submission order (one FIFO per node, as a
  controller that loads one TX buffer at a time).
* Arbitration: when the bus is idle and something is pending, an arbitration event is scheduled
  at the current µs with priority ``PRIO_CAN``; so every frame submitted at that µs by timer
  ISRs (``PRIO_ISR``) competes. The head frame with the lowest identifier wins (equal
  identifiers, illegal on a real bus, go by submission order).
* The winner occupies the bus for ``frame_bits`` bit times (``ceil(bits * 1e6 / bitrate)`` µs;
  exactly ``bits`` µs at 1 Mbit/s, including the 3-bit intermission), then it is delivered to
  every *other* attached bus with ``timestamp = end_us / 1e6`` and the next arbitration runs at
  once among the frames pending at that moment.
* Not modelled: error frames, bit errors, ACK failure, bus-off, overload frames, remote frames
  (refused), extended ids (refused), CAN FD, oscillator tolerance.

Registry
--------
Networks register by channel name (``get_network``). Creating a second network on a channel
that is already registered raises :class:`~bus.errors.BusError` unless ``replace=True``, which
closes the old one (its buses are detached). :meth:`CanNetwork.close` unregisters.
"""

from __future__ import annotations

from collections import deque
from functools import lru_cache

import can

from bus.errors import BusError
from bus.scheduler import PRIO_CAN, Scheduler

__all__ = ["CanNetwork", "get_network", "frame_bits", "frame_bits_unstuffed", "crc15",
           "WINDOW_US"]

#: Width of the windows over which ``stats()["peak_load_pct"]`` is taken, µs.
WINDOW_US = 100_000

# ------------------------------------------------------------------------------------------------
# Bit-exact frame length
# ------------------------------------------------------------------------------------------------
_CRC15_POLY = 0x4599


def _make_crc_table() -> tuple:
    table = []
    for i in range(256):
        r = i << 7
        for _ in range(8):
            r = ((r << 1) ^ _CRC15_POLY) if r & 0x4000 else (r << 1)
            r &= 0x7FFF
        table.append(r)
    return tuple(table)


_CRC_TABLE = _make_crc_table()


def _crc_step8(crc: int, byte: int) -> int:
    return ((crc << 8) & 0x7FFF) ^ _CRC_TABLE[((crc >> 7) ^ byte) & 0xFF]


def crc15(bits: int, nbits: int) -> int:
    """CAN CRC-15 (polynomial 0x4599, initial value 0) of the ``nbits``-bit big-endian ``bits``.

    Table-driven, one byte per step (the frame path uses a 16-bit table); the stream is
    left-padded with zeros to whole bytes, which does not change a CRC whose initial value is 0.
    """
    crc = 0
    for byte in bits.to_bytes((nbits + 7) >> 3, "big"):
        crc = _crc_step8(crc, byte)
    return crc


def _make_stuff_table() -> bytes:
    """Per (state, byte): stuff bits added and the next state.

    State = (value of the current run, its length 1..4) encoded as ``value * 4 + length - 1``;
    a run reaching 5 inserts a complementary stuff bit, which starts a new run of length 1.
    Entry = ``stuffs * 8 + new_state``.
    """
    table = bytearray(8 * 256)
    for state in range(8):
        for byte in range(256):
            value, length = state >> 2, (state & 3) + 1
            stuffs = 0
            for k in range(7, -1, -1):
                bit = (byte >> k) & 1
                if bit == value:
                    length += 1
                else:
                    value, length = bit, 1
                if length == 5:
                    stuffs += 1
                    value, length = value ^ 1, 1
            table[state * 256 + byte] = stuffs * 8 + value * 4 + length - 1
    return bytes(table)


_STUFF_TABLE = _make_stuff_table()

# 16-bit versions (composed from the 8-bit tables, built on first use: ~0.1 s, 640 kB)
_CRC16 = None
_STUFF16 = None


def _build_wide_tables() -> None:
    global _CRC16, _STUFF16
    from array import array

    crc_hi = [_crc_step8(0, hi) for hi in range(256)]
    _CRC16 = array("H", [_crc_step8(c, lo) for c in crc_hi for lo in range(256)])
    t8 = _STUFF_TABLE
    wide = bytearray(8 * 65536)
    for state in range(8):
        base = state << 16
        for hi in range(256):
            e1 = t8[(state << 8) | hi]
            s1 = e1 & ~7
            row = t8[(e1 & 7) << 8:((e1 & 7) + 1) << 8]
            wide[base | (hi << 8):base | ((hi + 1) << 8)] = bytes(s1 + e for e in row)
    _STUFF16 = bytes(wide)


def frame_bits_unstuffed(data_len: int) -> int:
    """Bits of a CAN 2.0A data frame without stuff bits: 47 + 8 × ``data_len`` (incl. 3-bit IFS)."""
    return 47 + 8 * data_len


@lru_cache(maxsize=8192)
def frame_bits(arbitration_id: int, data: bytes) -> int:
    """Exact length in bits of a CAN 2.0A data frame on the wire, including stuff bits.

    SOF, 11-bit identifier, RTR, IDE, r0, 4-bit DLC, data, 15-bit CRC (computed), then the stuff
    bits counted over SOF..end of CRC, then CRC delimiter, ACK slot, ACK delimiter, 7 EOF bits
    and the 3-bit intermission. An 8-byte frame is 111 bits unstuffed, at most 135.

    Parameters
    ----------
    arbitration_id : int
        Standard identifier, 0..0x7FF.
    data : bytes
        0..8 data bytes (must be hashable: ``bytes``, not ``bytearray``; results are cached).

    Returns
    -------
    int
        Bit count (= µs at 1 Mbit/s).
    """
    n = len(data)
    if not 0 <= arbitration_id <= 0x7FF or n > 8:
        raise BusError(f"frame_bits: need an 11-bit id and <= 8 data bytes, got "
                       f"id=0x{arbitration_id:X}, {n} bytes")
    if _CRC16 is None:
        _build_wide_tables()
    crc_t = _CRC16
    # SOF(0) | id(11) | RTR(0) IDE(0) r0(0) | DLC(4): 19 bits, then 8n data bits
    nbits = 19 + 8 * n
    stream = (((arbitration_id << 7) | n) << (8 * n)) | int.from_bytes(data, "big")
    # CRC-15, 16 bits per step; zero left-padding to whole 16-bit words is harmless
    crc = 0
    words = (nbits + 15) >> 4
    raw = stream.to_bytes(words * 2, "big")
    for i in range(0, words * 2, 2):
        crc = crc_t[((crc << 1) ^ (raw[i] << 8) ^ raw[i + 1]) & 0xFFFF]
    stream = (stream << 15) | crc
    nbits += 15                      # 34 + 8n bits: SOF .. end of CRC
    # stuffing: first two bits (SOF = 0, id bit 10) by hand, then 16 bits per step
    state = 4 if arbitration_id & 0x400 else 1   # run of one 1 / run of two 0s
    rest = nbits - 2                 # 32 + 8n
    raw = (stream & ((1 << rest) - 1)).to_bytes(rest >> 3, "big")
    stuff_t = _STUFF16
    stuffs = 0
    end = len(raw) & ~1
    for i in range(0, end, 2):
        entry = stuff_t[(state << 16) | (raw[i] << 8) | raw[i + 1]]
        stuffs += entry >> 3
        state = entry & 7
    if end < len(raw):
        stuffs += _STUFF_TABLE[(state << 8) | raw[end]] >> 3
    return nbits + stuffs + 13       # + CRC delim, ACK slot, ACK delim, 7 EOF, 3 IFS


# ------------------------------------------------------------------------------------------------
# The network
# ------------------------------------------------------------------------------------------------
_REGISTRY: dict[str, "CanNetwork"] = {}


def get_network(channel: str) -> "CanNetwork":
    """Return the network registered under ``channel``.

    Raises
    ------
    BusError
        If no :class:`CanNetwork` was created for that channel (it needs a scheduler, so it
        cannot be made implicitly).
    """
    try:
        return _REGISTRY[channel]
    except KeyError:
        raise BusError(
            f"no CanNetwork on channel {channel!r}; create CanNetwork(scheduler, {channel!r}) "
            f"first (registered: {sorted(_REGISTRY)})") from None


class _Pending:
    __slots__ = ("bus", "msg", "arbitration_id", "data", "submit_us", "seq")

    def __init__(self, bus, msg, arbitration_id, data, submit_us, seq):
        self.bus = bus
        self.msg = msg
        self.arbitration_id = arbitration_id
        self.data = data
        self.submit_us = submit_us
        self.seq = seq


class CanNetwork:
    """One shared CAN 2.0A bus in simulated time.

    Parameters
    ----------
    scheduler : Scheduler
        The simulation clock.
    channel : str
        Registry name (python-can ``channel``), e.g. ``"telescope"``.
    bitrate : int
        Bit rate, bit/s (default 1 Mbit/s).
    replace : bool
        If a network is already registered under ``channel``: False (default) raises
        :class:`~bus.errors.BusError`; True closes it and registers this one.
    """

    def __init__(self, scheduler: Scheduler, channel: str = "telescope",
                 bitrate: int = 1_000_000, *, replace: bool = False) -> None:
        if bitrate <= 0:
            raise BusError(f"bitrate must be > 0 bit/s, got {bitrate}")
        old = _REGISTRY.get(channel)
        if old is not None:
            if not replace:
                raise BusError(f"a CanNetwork on channel {channel!r} already exists; close() it "
                               f"or pass replace=True")
            old.close()
        self.scheduler = scheduler
        self.channel = channel
        self.bitrate = bitrate
        self._buses: list = []
        self._queues: dict[int, deque] = {}        # id(bus) -> deque of _Pending
        self._seq = 0
        self._busy = False
        self._arb_scheduled = False
        self._npending = 0
        self._current: _Pending | None = None
        self._start_us = scheduler.now_us
        # statistics
        self.frames = 0
        self.bits = 0
        self.busy_us = 0
        self.per_id: dict[int, int] = {}
        self.max_latency_us: dict[int, int] = {}
        self._window_busy: dict[int, int] = {}
        self.closed = False
        self._taps: list = []
        self._owner = f"can:{channel}"
        _REGISTRY[channel] = self

    # -- membership -------------------------------------------------------------------------
    def attach(self, bus) -> None:
        """Attach a bus (anything with ``_deliver(msg)``; normally a SimBus)."""
        if self.closed:
            raise BusError(f"CanNetwork {self.channel!r} is closed")
        if bus not in self._buses:
            self._buses.append(bus)
            self._queues[id(bus)] = deque()

    def detach(self, bus) -> None:
        """Detach a bus; its queued, not yet started frames are dropped."""
        if bus in self._buses:
            self._buses.remove(bus)
            self._npending -= len(self._queues.pop(id(bus)))

    @property
    def buses(self) -> tuple:
        """Attached buses, in attach order."""
        return tuple(self._buses)

    def close(self) -> None:
        """Shut down (detach) every bus and unregister the channel (idempotent)."""
        for bus in list(self._buses):
            shutdown = getattr(bus, "shutdown", None)
            if shutdown is not None:
                shutdown()
            self.detach(bus)
        self.closed = True
        if _REGISTRY.get(self.channel) is self:
            del _REGISTRY[self.channel]

    # -- transmission -----------------------------------------------------------------------
    def submit(self, bus, msg) -> None:
        """Queue ``msg`` (a ``can.Message``) from ``bus`` for arbitration. Never blocks.

        The identifier and a ``bytes`` snapshot of the data are taken now: the sender may reuse
        its Message object immediately.

        Raises
        ------
        BusError
            Extended, remote, error or FD frames, ids > 0x7FF, > 8 bytes, or a detached bus.
        """
        queue = self._queues.get(id(bus))
        if queue is None:
            raise BusError(f"bus {bus!r} is not attached to CanNetwork {self.channel!r}")
        aid = msg.arbitration_id
        if msg.is_extended_id or aid > 0x7FF or aid < 0:
            raise BusError(f"CAN 2.0A only: 11-bit standard ids (is_extended_id=False), "
                           f"got 0x{aid:X} extended={msg.is_extended_id}")
        if msg.is_remote_frame or msg.is_error_frame or msg.is_fd:
            raise BusError("remote, error and FD frames are not emulated")
        data = bytes(msg.data)
        if len(data) > 8:
            raise BusError(f"CAN 2.0A carries at most 8 data bytes, got {len(data)}")
        self._seq += 1
        self._npending += 1
        queue.append(_Pending(bus, msg, aid, data, self.scheduler.now_us, self._seq))
        if not self._busy and not self._arb_scheduled:
            self._arb_scheduled = True
            self.scheduler.call_at(self.scheduler.now_us, self._arbitrate, PRIO_CAN,
                                   owner=self._owner)

    def _arbitrate(self, now_us: int) -> None:
        self._arb_scheduled = False
        if not self._npending:
            self._busy = False
            return
        best = None
        best_key = None
        for queue in self._queues.values():
            if queue:
                head = queue[0]
                key = (head.arbitration_id, head.seq)
                if best_key is None or key < best_key:
                    best, best_key = head, key
        if best is None:
            self._busy = False
            return
        self._queues[id(best.bus)].popleft()
        self._npending -= 1
        bits = frame_bits(best.arbitration_id, best.data)
        if self.bitrate == 1_000_000:
            dur_us = bits
        else:
            dur_us = -((-bits * 1_000_000) // self.bitrate)
        self._busy = True
        latency = now_us - best.submit_us
        aid = best.arbitration_id
        if latency > self.max_latency_us.get(aid, -1):
            self.max_latency_us[aid] = latency
        self._account(now_us, dur_us, bits, aid)
        self._current = best
        self.scheduler.call_at(now_us + dur_us, self._complete, PRIO_CAN, owner=self._owner)

    def _account(self, start_us: int, dur_us: int, bits: int, aid: int) -> None:
        self.frames += 1
        self.bits += bits
        self.busy_us += dur_us
        self.per_id[aid] = self.per_id.get(aid, 0) + 1
        win = self._window_busy
        t, end = start_us, start_us + dur_us
        while t < end:
            w = t // WINDOW_US
            upto = min(end, (w + 1) * WINDOW_US)
            win[w] = win.get(w, 0) + upto - t
            t = upto

    def _complete(self, now_us: int) -> None:
        pending = self._current
        self._current = None
        sender = pending.bus

        msg = can.Message(timestamp=now_us / 1e6, arbitration_id=pending.arbitration_id,
                          is_extended_id=False, data=bytearray(pending.data),
                          channel=self.channel, is_rx=True)
        for tap in self._taps:
            tap(msg)
        interrupts = []
        for bus in self._buses:
            if bus is not sender:
                fire = bus._deliver(msg)
            elif getattr(bus, "receive_own_messages", False):
                fire = bus._deliver(can.Message(timestamp=msg.timestamp, arbitration_id=msg.arbitration_id,
                                                is_extended_id=False, data=bytearray(pending.data),
                                                channel=self.channel, is_rx=False))
            else:
                continue
            if fire:
                interrupts.append(bus)
        # Receive interrupts run at the frame's end time, after every receiver has the frame
        # (inline: same time and priority as a separate PRIO_CAN event, one heap operation less).
        # A frame a handler sends now joins the arbitration below.
        for bus in interrupts:
            bus._fire(now_us)
        self._arbitrate(now_us)

    def add_tap(self, fn) -> None:
        """Call ``fn(msg)`` with every frame at the end of its transmission (a bus monitor,
        like ``candump`` on a real bus). ``msg`` is shared read-only; the tap sees every frame
        whatever the receivers' acceptance filters."""
        self._taps.append(fn)

    @property
    def busy(self) -> bool:
        """True while a frame is on the wire."""
        return self._busy

    def pending_frames(self) -> int:
        """Frames queued, not yet on the wire."""
        return sum(len(q) for q in self._queues.values())

    # -- statistics -------------------------------------------------------------------------
    def stats(self) -> dict:
        """Traffic statistics since creation.

        Returns
        -------
        dict
            ``frames``; ``bits`` (incl. stuffing and intermission); ``busy_us``; ``elapsed_us``;
            ``load_pct`` = 100 · busy_us / elapsed_us; ``peak_load_pct`` = highest load over the
            complete 100 ms windows (aligned to t = 0; if no window is complete yet, the load of
            the partial one so far); ``per_id`` {id: frames}; ``max_latency_us`` {id: longest
            wait from submit to start of transmission, µs}; ``pending`` frames queued now.
            Frames in flight are counted from their start.
        """
        now = self.scheduler.now_us
        elapsed = now - self._start_us
        done = [busy for w, busy in self._window_busy.items() if (w + 1) * WINDOW_US <= now]
        if done:
            peak = 100.0 * max(done) / WINDOW_US
        else:
            w0 = max(self._start_us, (now // WINDOW_US) * WINDOW_US)
            span = now - w0
            peak = 100.0 * self._window_busy.get(now // WINDOW_US, 0) / span if span else 0.0
        return {
            "frames": self.frames,
            "bits": self.bits,
            "busy_us": self.busy_us,
            "elapsed_us": elapsed,
            "load_pct": 100.0 * self.busy_us / elapsed if elapsed > 0 else 0.0,
            "peak_load_pct": peak,
            "per_id": dict(sorted(self.per_id.items())),
            "max_latency_us": dict(sorted(self.max_latency_us.items())),
            "pending": self.pending_frames(),
        }

    def __repr__(self) -> str:
        return (f"<CanNetwork {self.channel!r} {self.bitrate} bit/s, {len(self._buses)} buses, "
                f"{self.frames} frames>")
