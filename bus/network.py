"""The emulated shared CAN bus: CAN 2.0A bit timing, arbitration and delivery in simulated time.

A :class:`CanNetwork` is one physical bus (one ``channel`` name). :class:`bus.simbus.SimBus`
objects attach to it; ``SimBus.send`` hands the frame to :meth:`CanNetwork.submit`.

Model
-----
* Each attached bus has a TX queue kept in submission order (one FIFO per node), unless it asks
  for hardware transmit buffers (``SimBus.set_tx_buffers``; the boards' CAN controllers do):
  then :class:`TxBuffers` models the MCP2515 / PIC18 ECAN transmit side — three buffers, the one
  with the highest TXP offered first, equal TXP: the highest buffer number (DS21801 §3.2), with
  the firmware's FIFO in front. Either way a node offers one frame per arbitration.
* Arbitration: when the bus is idle and something is pending, an arbitration event is scheduled
  at the current µs with priority ``PRIO_ARBITRATION``, after every other event of that µs; so
  every frame submitted at that µs — by timer ISRs, background loops, receive handlers or the
  host — competes (before session 22 the event ran at ``PRIO_CAN``, so the first background
  loop's frame went first whatever its identifier). The head frame with the lowest identifier
  wins (equal identifiers, illegal on a real bus, go by submission order).
* The winner occupies the bus for ``frame_bits`` bit times (``ceil(bits * 1e6 / bitrate)`` µs;
  exactly ``bits`` µs at 1 Mbit/s, including the 3-bit intermission), then it is delivered to
  every *other* attached bus whose acceptance filters pass it, with ``timestamp = end_us / 1e6``,
  and the next arbitration runs at once among the frames pending at that moment.
* Cost: delivery walks a table identifier → accepting receivers (rebuilt when a bus attaches,
  detaches or changes filters), so it scales with the receivers of a frame, not with the nodes;
  fault-free arbitration pops a heap of queue heads. Neither changes who gets what, or when.
* Fault confinement (ISO 11898-1 §12), active only once a fault is injected (the fault-free
  path is unchanged): see :class:`NodeErrorState` and :meth:`CanNetwork.inject_errors`. A frame
  that meets an error occupies the bus up to the bit where the error is detected, then an error
  frame follows (6-bit error flag + 6 echoed flag bits + 8-bit delimiter + 3-bit intermission =
  23 bit times, the worst-case superposition), the transmitter's TEC += 8, every receiver's
  REC += 1, and the frame goes back to the head of its sender's queue: it is retransmitted
  automatically at the next arbitration. An error-passive transmitter waits 8 more bit times
  (suspend transmission) before it may compete again. TEC > 255 puts the node bus-off: its queued
  frames are dropped and ``send`` raises ``can.CanOperationError`` until recovery, which takes
  128 occurrences of 11 consecutive recessive bits once requested (each completed frame's
  ACK delimiter + EOF + intermission is one occurrence, idle bus time counts one per 11 bit
  times). Successful transmit: TEC −= 1; successful receive: REC −= 1 (an REC above 127 is set
  to 127). Error-passive at TEC or REC ≥ 128, error-active again when both are ≤ 127.
* Simplifications (written down): a receiver's +8 for a dominant bit after its own error flag
  and the ACK-error exception for error-passive transmitters are not modelled; every receiver
  that is not bus-off detects every error; overload frames are not modelled.
* Not modelled: overload frames, remote frames (refused), extended ids (refused), CAN FD,
  oscillator tolerance.

Registry
--------
Networks register by channel name (``get_network``). Creating a second network on a channel
that is already registered raises :class:`~bus.errors.BusError` unless ``replace=True``, which
closes the old one (its buses are detached). :meth:`CanNetwork.close` unregisters.
"""

from __future__ import annotations

import functools
import random
from collections import deque

from typing import Any, Final, Optional

import can

from bus import bitkernel as _bitkernel
from bus.errors import BusError
from bus.jit_entry import entry_point
from bus.scheduler import PRIO_ARBITRATION, PRIO_CAN, Event, Scheduler

__all__ = ["CanNetwork", "TxBuffers", "RxFrame", "get_network", "frame_bits", "clear_frame_bits_cache",
           "frame_bits_unstuffed", "crc15",
           "WINDOW_US", "NodeErrorState", "ErrorRule", "ERROR_ACTIVE", "ERROR_PASSIVE", "BUS_OFF",
           "ERROR_FRAME_BITS", "RECOVERY_OCCURRENCES"]

#: Fault-confinement states (ISO 11898-1 §12.1).
ERROR_ACTIVE, ERROR_PASSIVE, BUS_OFF = "error-active", "error-passive", "bus-off"
#: Bits of an active error frame incl. intermission: 6 flag + 6 echoed + 8 delimiter + 3 IFS.
ERROR_FRAME_BITS: Final = 23
#: Suspend-transmission time of an error-passive transmitter, bits (ISO 11898-1).
SUSPEND_BITS: Final = 8
#: Bus-off recovery: this many occurrences of 11 consecutive recessive bits.
RECOVERY_OCCURRENCES: Final = 128

#: Width of the windows over which ``stats()["peak_load_pct"]`` is taken, µs.
WINDOW_US: Final = 100_000

# ------------------------------------------------------------------------------------------------
# Bit-exact frame length
# ------------------------------------------------------------------------------------------------
_CRC15_POLY: Final = 0x4599


def _make_crc_table() -> tuple:
    table = []
    for i in range(256):
        r = i << 7
        for _ in range(8):
            r = ((r << 1) ^ _CRC15_POLY) if r & 0x4000 else (r << 1)
            r &= 0x7FFF
        table.append(r)
    return tuple(table)


_CRC_TABLE: Final = _make_crc_table()


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


_STUFF_TABLE: Final = _make_stuff_table()

# 16-bit versions (composed from the 8-bit tables, built on first use: ~0.1 s, 640 kB)
_CRC16: Any = None
_STUFF16: Any = None


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


def _frame_bits_tables(arbitration_id: int, data: bytes) -> int:
    """:func:`frame_bits` computed with 16-bit CRC and stuffing tables, interpreted (used when
    numba is not available; same arguments, result and errors)."""
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


#: the cache of :func:`frame_bits`: indexed by the identifier, ``{data: bits}`` (one list index
#: and one dictionary lookup, no key tuple built; ``functools.lru_cache`` cost ≈ 3 % of the
#: ``full`` network's instructions, session 8).
#: At most :data:`_BITS_PER_ID` payloads are kept per identifier: status frames change their
#: data every period, so an hour-long run would otherwise grow it without bound.
_BITS_CACHE: Final[list[Optional[dict[bytes, int]]]] = [None] * 0x800
_BITS_PER_ID: Final = 256
#: the compiled bit-serial kernel (its entry point for four ``int64``: no numba type dispatch per
#: frame, :mod:`bus.jit_entry`), or None without numba (then the tables)
_BITS_KERNEL: Final[Any] = (entry_point(_bitkernel.frame_bits_kernel, (0x7FF, 8, 0, 0)) if _bitkernel.JIT
                            else None)


def clear_frame_bits_cache() -> None:
    """Empty the cache of :func:`frame_bits` (tests that time or compare its two paths)."""
    _BITS_CACHE[:] = [None] * 0x800


def frame_bits(arbitration_id: int, data: bytes) -> int:
    """Exact length in bits of a CAN 2.0A data frame on the wire, including stuff bits.

    SOF, 11-bit identifier, RTR, IDE, r0, 4-bit DLC, data, 15-bit CRC (computed), then the stuff
    bits counted over SOF..end of CRC, then CRC delimiter, ACK slot, ACK delimiter, 7 EOF bits
    and the 3-bit intermission. An 8-byte frame is 111 bits unstuffed, at most 135.

    Computed by the compiled bit-serial kernel :func:`bus.bitkernel.frame_bits_kernel` when numba
    is available (≈ 0.5 µs; a miss of the cache below happens for most status frames, whose data
    change every period), else by the table-driven :func:`_frame_bits_tables` (≈ 5–10 µs);
    tests/test_bus_network.py checks that both agree with a bit-by-bit reference.

    Parameters
    ----------
    arbitration_id : int
        Standard identifier, 0..0x7FF.
    data : bytes
        0..8 data bytes (``bytes``; results are cached per identifier).

    Returns
    -------
    int
        Bit count (= µs at 1 Mbit/s).

    Raises
    ------
    BusError
        For an identifier above 0x7FF or more than 8 data bytes.
    """
    per_id = _BITS_CACHE[arbitration_id] if 0 <= arbitration_id <= 0x7FF else None
    if per_id is not None:
        cached = per_id.get(data)
        if cached is not None:
            return cached
    n = len(data)
    if not 0 <= arbitration_id <= 0x7FF or n > 8:
        raise BusError(f"frame_bits: need an 11-bit id and <= 8 data bytes, got "
                       f"id=0x{arbitration_id:X}, {n} bytes")
    bits: int
    if _BITS_KERNEL is not None:
        v = int.from_bytes(data, "big")
        bits = int(_BITS_KERNEL(arbitration_id, n, v >> 32, v & 0xFFFFFFFF))
    else:
        bits = _frame_bits_tables(arbitration_id, data)
    if per_id is None:
        per_id = {}
        _BITS_CACHE[arbitration_id] = per_id
    elif len(per_id) >= _BITS_PER_ID:
        per_id.clear()
    per_id[bytes(data)] = bits
    return bits


# ------------------------------------------------------------------------------------------------
# The network
# ------------------------------------------------------------------------------------------------
_REGISTRY: Final[dict[str, "CanNetwork"]] = {}


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


#: The slots of ``can.Message`` that :func:`_rx_message` fills (python-can 4.x).
_MESSAGE_SLOTS: Final = frozenset({"timestamp", "arbitration_id", "is_extended_id", "is_remote_frame",
                            "is_error_frame", "channel", "dlc", "data", "is_fd", "is_rx",
                            "bitrate_switch", "error_state_indicator"})
_Message: Final = can.Message


def _rx_message_fast(timestamp: float, arbitration_id: int, data: bytes, channel, is_rx: bool):
    m = _Message.__new__(_Message)
    m.timestamp = timestamp
    m.arbitration_id = arbitration_id
    m.is_extended_id = False
    m.is_remote_frame = False
    m.is_error_frame = False
    m.channel = channel
    m.dlc = len(data)
    m.data = bytearray(data)
    m.is_fd = False
    m.is_rx = is_rx
    m.bitrate_switch = False
    m.error_state_indicator = False
    return m


def _rx_message_init(timestamp: float, arbitration_id: int, data: bytes, channel, is_rx: bool):
    return _Message(timestamp=timestamp, arbitration_id=arbitration_id, is_extended_id=False,
                    data=bytearray(data), channel=channel, is_rx=is_rx)


#: The received frame as a ``can.Message``, equal to ``can.Message(timestamp=..., arbitration_id=...,
#: is_extended_id=False, data=bytearray(data), channel=..., is_rx=...)``; built without
#: ``__init__``'s argument handling (half the cost) when python-can's slots are the known ones,
#: else by the constructor (tests/test_bus_network.py checks the two agree).
_rx_message: Final = (_rx_message_fast if set(getattr(_Message, "__slots__", ())) - {"__weakref__"} == _MESSAGE_SLOTS
               else _rx_message_init)


class RxFrame:
    """A received standard data frame inside the in-process bus: the end time and the frame.

    :class:`~bus.simbus.SimBus` queues these and builds the ``can.Message`` only when a program
    reads the frame (``recv``, ``drain_rx``); the emulated boards' CAN controllers take them as
    they are (:meth:`SimBus.drain_rx_frames`). Building a python-can ``Message`` for every
    delivery was ≈ 5 % of the ``full`` network's instructions, and reading its attributes from
    compiled code goes through the generic attribute protocol (docs/performance.md, session 8).

    Attributes
    ----------
    t_us : int
        End of the frame on the wire, µs (the Message's ``timestamp`` is ``t_us / 1e6`` s).
    arbitration_id : int
        11-bit identifier (the bus emulates standard data frames only).
    data : bytes
        0..8 data bytes.
    """

    __slots__ = ("t_us", "arbitration_id", "data")

    def __init__(self, t_us: int, arbitration_id: int, data: bytes) -> None:
        self.t_us = t_us
        self.arbitration_id = arbitration_id
        self.data = data

    def message(self, channel: Any, is_rx: bool = True) -> can.Message:
        """The frame as the ``can.Message`` a python-can receiver gets."""
        return _rx_message(self.t_us / 1e6, self.arbitration_id, self.data, channel, is_rx)

    def __repr__(self) -> str:
        return f"RxFrame(t_us={self.t_us}, arbitration_id=0x{self.arbitration_id:03X}, data={self.data.hex()})"


class TxBuffers:
    """A node's transmit side with hardware transmit buffers, as the MCP2515 (DS21801 §3) and the
    PIC18F4480 ECAN module in mode 0 (DS39637 §24.6) have it, in front of the firmware's FIFO.

    Datasheet rule (MCP2515 DS21801 §3.2 "Transmit Priority"; PIC18F2480/2580/4480/4580
    DS39637 §24.6.3, same words): prior to sending the SOF, the priorities of all buffers queued
    for transmission are compared and the buffer with the highest priority (TXP<1:0>, 11 highest)
    is sent first; if two buffers have the same priority setting, the buffer with the highest
    buffer number is sent first. This is independent of the CAN identifier; the frame the
    controller offers then competes in the bus's identifier arbitration, and a frame that loses
    (or meets an error) stays in its buffer and is compared again before the next SOF.

    Firmware side (an assumption, docs/architecture.md): frames the firmware sends wait in a
    software FIFO (unbounded in the model) when no buffer is free; whenever a buffer is free the
    oldest waiting frame is loaded into the lowest-numbered free buffer with the TXP that
    ``tx_priority(arbitration_id)`` gives, at once (the transmit-complete interrupt's latency is
    not modelled). A buffer frees when its frame completes on the wire.

    The network uses it through the deque operations of its per-node FIFO: ``append`` (the
    firmware sends), ``[0]`` (the frame the controller offers now), ``popleft`` (that frame
    starts on the wire: its buffer stays taken until :meth:`sent`), ``appendleft`` (it met an
    error: back to pending in its buffer), ``len`` (frames waiting, buffered or in the FIFO, not
    the one on the wire), ``clear`` (bus-off).

    Parameters
    ----------
    n : int
        Transmit buffers (3: TXB0..TXB2).
    tx_priority : callable(int) -> int
        TXP (0..3) the firmware gives a frame with this identifier.
    """

    __slots__ = ("n", "tx_priority", "buf", "fifo", "_cand", "_sending", "_count", "head", "_txp")

    def __init__(self, n: int, tx_priority) -> None:
        if int(n) < 1:
            raise BusError(f"a controller needs at least one transmit buffer, got {n}")
        self.n = int(n)
        self.tx_priority = tx_priority
        #: per buffer number: (pending, rank) or None; rank = TXP * n + buffer number, so the
        #: highest rank is the buffer the datasheet rule picks
        self.buf: list = [None] * self.n
        self.fifo: deque = deque()           # the firmware's software queue
        self._cand: Any = None               # buffer number of the frame offered next
        self._sending: Any = None                 # buffer number whose frame is on the wire
        self._count = 0                      # frames waiting: buffered (not on the wire) + FIFO
        #: the frame offered next (``self[0]``), None when nothing waits in a buffer
        self.head: Any = None
        self._txp: dict[int, int] = {}       # identifier -> TXP, asked once per identifier

    def _rank(self, arbitration_id: int, i: int) -> int:
        txp = self._txp.get(arbitration_id)
        if txp is None:
            txp = self.tx_priority(arbitration_id)
            if txp.__class__ is not int or not 0 <= txp <= 3:
                raise BusError(f"TXP must be an int 0..3, got {txp!r} for 0x{arbitration_id:03X}")
            self._txp[arbitration_id] = txp
        return txp * self.n + i

    def _load(self) -> None:
        buf, fifo, n = self.buf, self.fifo, self.n
        for i in range(n):
            if not fifo:
                return
            if buf[i] is None:
                p = fifo.popleft()
                buf[i] = (p, self._rank(p.arbitration_id, i))

    def _select(self) -> None:
        # entries read through _rank_of/_pending_of: native item reads and int compares
        best, best_rank, sending = None, -1, self._sending
        buf = self.buf
        for i in range(len(buf)):
            e = buf[i]
            if e is not None and i != sending:
                rank = _rank_of(e)
                if rank > best_rank:
                    best, best_rank = i, rank
        self._cand = best
        self.head = None if best is None else _pending_of(buf[best])

    def append(self, pending) -> None:
        self._count += 1
        buf = self.buf
        if not self.fifo:                    # fast path: into the lowest-numbered free buffer
            for i in range(self.n):
                if buf[i] is None:
                    txp = self._txp.get(pending.arbitration_id)
                    rank = (txp * self.n + i) if txp is not None else self._rank(pending.arbitration_id, i)
                    buf[i] = (pending, rank)
                    c = self._cand
                    if c is None or rank > _rank_of(buf[c]):
                        self._cand = i
                        self.head = pending
                    return
        self.fifo.append(pending)            # every buffer taken: the firmware's FIFO

    def __getitem__(self, k: int) -> Any:
        c = self._cand
        if k != 0 or c is None:
            raise IndexError("TxBuffers: only [0], the frame offered next, when one is pending")
        return _pending_of(self.buf[c])

    def popleft(self) -> Any:
        c = self._cand
        if c is None:
            raise IndexError("TxBuffers: nothing pending")
        self._sending = c
        self._count -= 1
        self._select()
        return _pending_of(self.buf[c])

    def appendleft(self, pending) -> None:
        c = self._sending
        if c is None or _pending_of(self.buf[c]) is not pending:
            raise BusError("TxBuffers: only the frame on the wire can go back to pending")
        self._sending = None
        self._count += 1
        self._select()

    def sent(self, pending) -> None:
        """``pending`` completed on the wire: its buffer frees and the firmware refills it."""
        c = self._sending
        if c is not None and _pending_of(self.buf[c]) is pending:
            self.buf[c] = None
            self._sending = None
            if self.fifo:
                self._load()
                self._select()

    def clear(self) -> None:
        self.buf = [None] * self.n
        self.fifo.clear()
        self._cand = self._sending = self.head = None
        self._count = 0

    def __len__(self) -> int:
        return self._count

    def __bool__(self) -> bool:
        return self._cand is not None


class _Pending:
    __slots__ = ("bus", "arbitration_id", "data", "submit_us", "seq", "key")

    def __init__(self, bus: Any, arbitration_id: int, data: bytes, submit_us: int, seq: int) -> None:
        self.bus = bus
        self.arbitration_id = arbitration_id
        self.data = data
        self.submit_us = submit_us
        self.seq = seq
        #: arbitration order, as the tuple (identifier, seq) but one integer compare
        self.key = (arbitration_id << 48) | seq


def _pending_of(entry: tuple) -> Any:
    """The frame of a :class:`TxBuffers` entry ``(pending, rank)`` (a typed, native read)."""
    return entry[0]


def _rank_of(entry: tuple) -> int:
    """The rank of a :class:`TxBuffers` entry ``(pending, rank)``."""
    return entry[1]


def _heads_push(heap: list[_Pending], item: _Pending) -> None:
    """Push onto the arbitration heap, ordered by :attr:`_Pending.key` (``heapq.heappush`` on
    the frames themselves: compiled, a C compare of two integer fields and no ``(key, frame)``
    tuple per push; session 9)."""
    heap.append(item)
    pos = len(heap) - 1
    key = item.key
    while pos > 0:
        parent_pos = (pos - 1) >> 1
        parent = heap[parent_pos]
        if key < parent.key:
            heap[pos] = parent
            pos = parent_pos
            continue
        break
    heap[pos] = item


def _heads_pop(heap: list[_Pending]) -> _Pending:
    """Remove and return the frame with the smallest key (``heapq.heappop``)."""
    last = heap.pop()
    if not heap:
        return last
    first = heap[0]
    end = len(heap)
    pos = 0
    key = last.key
    child = 1
    while child < end:
        right = child + 1
        if right < end and heap[right].key < heap[child].key:
            child = right
        if heap[child].key < key:
            heap[pos] = heap[child]
            pos = child
            child = 2 * pos + 1
        else:
            break
    heap[pos] = last
    return first


class NodeErrorState:
    """Fault-confinement state of one attached node (what a controller's TEC/REC registers hold).

    Attributes
    ----------
    tec, rec : int
        Transmit / receive error counters (0..256 / 0..255+).
    state : str
        :data:`ERROR_ACTIVE`, :data:`ERROR_PASSIVE` or :data:`BUS_OFF`.
    tx_errors, rx_errors : int
        Errors met as transmitter / detected as receiver.
    retransmissions : int
        Frames put back for automatic retransmission after an error.
    bus_off_count : int
        Times the node went bus-off.
    dropped_bus_off : int
        Frames discarded because the node was (or went) bus-off.
    frames_lost : int
        Frames this node did not receive because of an injected ``loss`` rule.
    recovery_requested : bool
        True while a bus-off recovery is pending.
    """

    __slots__ = ("name", "tec", "rec", "state", "tx_errors", "rx_errors", "retransmissions",
                 "bus_off_count", "dropped_bus_off", "frames_lost", "recovery_requested",
                 "auto_recover", "_rec_t0", "_rec_busy0", "_rec_frames0", "_rec_event",
                 "suspend_until_us")

    def __init__(self, name: str) -> None:
        self.name = name
        self.tec = self.rec = 0
        self.state = ERROR_ACTIVE
        self.tx_errors = self.rx_errors = self.retransmissions = 0
        self.bus_off_count = self.dropped_bus_off = self.frames_lost = 0
        self.recovery_requested = False
        self.auto_recover = False
        self._rec_t0 = self._rec_busy0 = self._rec_frames0 = 0
        self._rec_event = None
        self.suspend_until_us = 0

    def _update_state(self) -> None:
        if self.state == BUS_OFF:
            return
        if self.tec > 255:
            self.state = BUS_OFF
            self.bus_off_count += 1
        elif self.tec >= 128 or self.rec >= 128:
            self.state = ERROR_PASSIVE
        else:
            self.state = ERROR_ACTIVE

    def as_dict(self) -> dict:
        """Counters as a plain dict (for reports)."""
        return {"tec": self.tec, "rec": self.rec, "state": self.state,
                "tx_errors": self.tx_errors, "rx_errors": self.rx_errors,
                "retransmissions": self.retransmissions, "bus_off_count": self.bus_off_count,
                "dropped_bus_off": self.dropped_bus_off, "frames_lost": self.frames_lost}


class ErrorRule:
    """One injected fault on the wire (see :meth:`CanNetwork.inject_errors`)."""

    __slots__ = ("kind", "ids", "sender", "receivers", "probability", "remaining", "start_us",
                 "end_us", "hits")

    def __init__(self, kind, ids, sender, receivers, probability, count, start_us, end_us):
        self.kind = kind
        self.ids = ids
        self.sender = sender
        self.receivers = receivers
        self.probability = probability
        self.remaining = count
        self.start_us = start_us
        self.end_us = end_us
        self.hits = 0

    def matches(self, now_us: int, sender, aid: int, rng) -> bool:
        if self.remaining is not None and self.remaining <= 0:
            return False
        if now_us < self.start_us or (self.end_us is not None and now_us >= self.end_us):
            return False
        if self.ids is not None and aid not in self.ids:
            return False
        if self.sender is not None and sender is not self.sender:
            return False
        if self.probability < 1.0 and rng.random() >= self.probability:
            return False
        if self.remaining is not None:
            self.remaining -= 1
        self.hits += 1
        return True


class _InjectedNode:
    """A node that only transmits (the babbling node of :meth:`CanNetwork.babble`)."""

    receive_own_messages = False

    def __init__(self, name: str) -> None:
        self.name = name
        self._babble: Any = None          # (identifier, data, end_us), set by babble()

    def _accepts(self, arbitration_id: int) -> bool:
        return False

    def _deliver(self, msg) -> bool:
        return False

    def _fire(self, now_us: int) -> None:
        pass


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
        self._queues: dict[Any, Any] = {}        # bus -> deque of _Pending (keyed by the bus object:
        #                                          no id() integer boxed and hashed per frame)
        self._active: dict[Any, Any] = {}        # the non-empty ones (what arbitration scans)
        #: fault-free path: a heap of the pending frames, by key, holding the head frame of every non-empty
        #: queue, so arbitration costs O(log nodes) however many nodes have a frame waiting
        #: (entries of detached buses are skipped when popped). Once a fault is injected the
        #: network scans ``_active`` instead (suspend times, retransmissions at the head).
        self._heads: list[_Pending] = []
        self._seq = 0
        self._busy = False
        self._arb_scheduled = False
        self._npending = 0
        self._current: Optional[_Pending] = None     # the frame on the wire
        #: identifier -> ((bus, enqueue), ...): the attached buses whose acceptance filters pass
        #: that identifier, in attach order, built on first use and dropped whenever a bus is
        #: attached, detached or changes its filters. Delivery then costs per *accepting*
        #: receiver, not per attached node.
        self._rx_table: list[Optional[tuple]] = [None] * 0x800
        #: incremented whenever the receivers table is cleared (see :meth:`_complete`)
        self._rx_table_gen = 0
        self._start_us = scheduler.now_us
        # statistics
        self.frames = 0
        self.bits = 0
        self.busy_us = 0
        #: frames sent and longest submit-to-start wait [µs] per identifier, indexed by it
        #: (lists: no boxed integer key hashed and compared per frame); -1: never sent
        self._frames_by_id: list[int] = [0] * 0x800
        self._max_latency_by_id: list[int] = [-1] * 0x800
        self._window_busy: dict[int, int] = {}
        self.closed = False
        self._taps: list = []
        self._owner = f"can:{channel}"
        # the one-shot events of arbitration and frame completion, reused once spent
        self._arb_event = Event(0, PRIO_ARBITRATION, self._arbitrate, self._owner, None)
        self._complete_event = Event(0, PRIO_CAN, self._complete, self._owner, None)
        self._arb_event.cancelled = self._complete_event.cancelled = True     # not queued
        # fault confinement (inactive until a fault is injected: fast path unchanged)
        self._faulty = False
        self._rules: list = []
        self._errors: dict = {}          # bus -> NodeErrorState
        self.rng = random.Random(0)
        self.error_frames = 0
        self.error_bits = 0
        self._babblers: dict = {}
        _REGISTRY[channel] = self

    # -- membership -------------------------------------------------------------------------
    def attach(self, bus) -> None:
        """Attach a bus (anything with ``_deliver(msg)``; normally a SimBus)."""
        if self.closed:
            raise BusError(f"CanNetwork {self.channel!r} is closed")
        if bus not in self._buses:
            self._buses.append(bus)
            self._queues[bus] = deque()
            self._errors[bus] = NodeErrorState(getattr(bus, "name", repr(bus)))
            self._clear_rx_table()

    def detach(self, bus) -> None:
        """Detach a bus; its queued, not yet started frames are dropped."""
        if bus in self._buses:
            self._buses.remove(bus)
            self._npending -= len(self._queues.pop(bus))
            self._active.pop(bus, None)
            self._errors.pop(bus, None)
            self._clear_rx_table()

    def set_tx_buffers(self, bus, n: int, tx_priority) -> None:
        """Give an attached node ``n`` hardware transmit buffers chosen by TXP
        (:class:`TxBuffers`: the MCP2515 / PIC18 ECAN transmit priority) instead of one FIFO.

        Raises
        ------
        BusError
            If ``bus`` is not attached, or has frames queued or on the wire.
        """
        q = self._queues.get(bus)
        if q is None:
            raise BusError(f"{bus!r} is not attached to CanNetwork {self.channel!r}")
        if q or (self._current is not None and self._current.bus is bus):
            raise BusError(f"set_tx_buffers: {bus!r} has frames queued")
        self._queues[bus] = TxBuffers(n, tx_priority)

    def filters_changed(self) -> None:
        """An attached bus changed its acceptance filters (SimBus calls this from
        ``set_filters`` and ``set_rx_callback``): the identifier -> receivers table is rebuilt
        on demand."""
        self._clear_rx_table()

    def _clear_rx_table(self) -> None:
        self._rx_table[:] = [None] * 0x800
        self._rx_table_gen += 1              # read by _complete: the cached callbacks are stale

    def _receivers(self, arbitration_id: int) -> tuple:
        """``((bus, enqueue, enqueue_frame, rx_callback), ...)`` for the buses that accept
        ``arbitration_id``, attach order.

        A bus with ``_accepts(id)`` (SimBus, the babbling node) is listed only if its filters
        pass the identifier, and then gets the frame through ``_enqueue(msg)`` (no second filter
        check) or, if it has one, ``_enqueue_frame(RxFrame)`` (no ``can.Message`` built); any
        other attached object is always listed and gets ``_deliver(msg)``, which filters.

        ``rx_callback``: a bus with ``_enqueue_frame`` (SimBus) is listed with its receive
        interrupt as it is now (``_rx_callback``), which :meth:`_complete` calls directly
        instead of through the bus's ``_fire`` (session 17: one Python-level call less per
        interrupt). So the bus must call :meth:`filters_changed` when it changes the callback
        (``SimBus.set_rx_callback`` does). Other objects get ``None`` there and their ``_fire``.
        """
        out = []
        for bus in self._buses:
            accepts = getattr(bus, "_accepts", None)
            if accepts is None:
                out.append((bus, bus._deliver, None, None))
            elif accepts(arbitration_id):
                enqueue_frame = getattr(bus, "_enqueue_frame", None)
                out.append((bus, bus._enqueue, enqueue_frame,
                            getattr(bus, "_rx_callback", None) if enqueue_frame is not None else None))
        entry = tuple(out)
        self._rx_table[arbitration_id] = entry
        return entry

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
        aid = msg.arbitration_id
        if msg.is_extended_id or aid > 0x7FF or aid < 0:
            if bus not in self._queues:
                raise BusError(f"bus {bus!r} is not attached to CanNetwork {self.channel!r}")
            raise BusError(f"CAN 2.0A only: 11-bit standard ids (is_extended_id=False), "
                           f"got 0x{aid:X} extended={msg.is_extended_id}")
        if msg.is_remote_frame or msg.is_error_frame or msg.is_fd:
            if bus not in self._queues:
                raise BusError(f"bus {bus!r} is not attached to CanNetwork {self.channel!r}")
            raise BusError("remote, error and FD frames are not emulated")
        self.submit_frame(bus, aid, bytes(msg.data))

    def submit_frame(self, bus, arbitration_id: int, data: bytes) -> None:
        """Queue a standard data frame from ``bus`` given as identifier and ``bytes`` (the fast
        path of :meth:`submit`, used by ``SimBus.send_frame``: no ``can.Message`` is built).

        Raises
        ------
        BusError
            An identifier outside 0..0x7FF, more than 8 bytes, or a detached bus.
        can.CanOperationError
            While the node is bus-off.
        """
        queue = self._queues.get(bus)
        if queue is None:
            raise BusError(f"bus {bus!r} is not attached to CanNetwork {self.channel!r}")
        aid = arbitration_id
        if aid > 0x7FF or aid < 0:
            raise BusError(f"CAN 2.0A only: 11-bit standard ids (is_extended_id=False), "
                           f"got 0x{aid:X} extended=False")
        if len(data) > 8:
            raise BusError(f"CAN 2.0A carries at most 8 data bytes, got {len(data)}")
        if self._faulty:
            es = self._errors[bus]
            if es.state == BUS_OFF:
                es.dropped_bus_off += 1
                raise can.CanOperationError(f"{es.name}: CAN controller is bus-off "
                                            f"(TEC {es.tec}); frame 0x{aid:03X} not sent")
        self._seq += 1
        self._npending += 1
        pending = _Pending(bus, aid, data, self.scheduler.now_us, self._seq)
        if queue.__class__ is TxBuffers:
            # typed: the compiled module calls TxBuffers natively (session 17)
            tq: TxBuffers = queue
            tq.append(pending)
            offered = tq.head
        else:
            queue.append(pending)
            offered = queue[0]                   # (a FIFO: it is the only one)
        self._active[bus] = queue
        if not self._faulty and offered is pending:
            _heads_push(self._heads, pending)
        if not self._busy and not self._arb_scheduled:
            self._arb_scheduled = True
            sched = self.scheduler
            ev = self._arb_event
            if ev.cancelled:                  # spent: reuse it (no Event built per frame)
                sched._reschedule_trusted(ev, sched.now_us)
            else:
                self._arb_event = sched._call_at_trusted(sched.now_us, self._arbitrate, PRIO_ARBITRATION,
                                                         self._owner)

    def _arbitrate(self, now_us: int) -> None:
        self._arb_scheduled = False
        if not self._npending:
            self._busy = False
            return
        best: Optional[_Pending] = None
        best_key: Optional[int] = None
        if self._faulty:
            errs = self._errors
            wake = None
            for node, queue in self._active.items():
                su = errs[node].suspend_until_us
                if su > now_us:              # error-passive transmitter in suspend transmission
                    wake = su if wake is None or su < wake else wake
                    continue
                head = queue[0]
                key = head.key
                if best_key is None or key < best_key:
                    best, best_key = head, key
            if best is None:
                self._busy = False
                if wake is not None:
                    self._arb_scheduled = True
                    self.scheduler.call_at(wake, self._arbitrate, PRIO_ARBITRATION, owner=self._owner)
                return
        else:
            heads = self._heads
            queues = self._queues
            while heads:
                head = _heads_pop(heads)
                queue = queues.get(head.bus)
                if queue is None:                    # its bus was detached meanwhile
                    continue
                if queue.__class__ is TxBuffers:
                    tq: TxBuffers = queue         # typed: native calls (session 17)
                    if tq.head is head:              # else no longer what the node offers
                        best = head
                        break
                elif queue and queue[0] is head:
                    best = head
                    break
        if best is None:
            self._busy = False
            return
        bus_key = best.bus
        queue = self._queues[bus_key]
        if queue.__class__ is TxBuffers:
            tq = queue
            tq.popleft()
            nxt = tq.head
            if tq._count == 0:
                del self._active[bus_key]
            elif nxt is not None and not self._faulty:
                _heads_push(self._heads, nxt)
        else:
            queue.popleft()
            if not queue:
                del self._active[bus_key]
            elif not self._faulty:
                _heads_push(self._heads, queue[0])
        self._npending -= 1
        bits = frame_bits(best.arbitration_id, best.data)
        if self.bitrate == 1_000_000:
            dur_us = bits
        else:
            dur_us = -((-bits * 1_000_000) // self.bitrate)
        self._busy = True
        if self._faulty and self._rules:
            rule = self._match(now_us, best, "corrupt")
            if rule is not None:
                self._error_on_wire(now_us, best, bits)
                return
        latency = now_us - best.submit_us
        aid = best.arbitration_id
        max_lat = self._max_latency_by_id
        if latency > max_lat[aid]:
            max_lat[aid] = latency
        self.frames += 1
        self.bits += bits
        self._frames_by_id[aid] += 1
        if now_us // WINDOW_US == (now_us + dur_us - 1) // WINDOW_US:    # within one load window
            self.busy_us += dur_us
            w = now_us // WINDOW_US
            win = self._window_busy
            win[w] = win.get(w, 0) + dur_us
        else:
            self._occupy(now_us, dur_us)
        self._current = best
        ev = self._complete_event
        if ev.cancelled:                      # spent: reuse it (no Event built per frame)
            self.scheduler._reschedule_trusted(ev, now_us + dur_us)
        else:
            self._complete_event = self.scheduler._call_at_trusted(now_us + dur_us, self._complete,
                                                                   PRIO_CAN, self._owner)

    def _occupy(self, start_us: int, dur_us: int) -> None:
        """Count ``dur_us`` of bus time from ``start_us`` (total and per 100 ms load window)."""
        self.busy_us += dur_us
        win = self._window_busy
        t, end = start_us, start_us + dur_us
        while t < end:
            w = t // WINDOW_US
            upto = min(end, (w + 1) * WINDOW_US)
            win[w] = win.get(w, 0) + upto - t
            t = upto

    def _complete(self, now_us: int) -> None:
        pending = self._current
        assert pending is not None            # the completion event runs only for a frame on the wire
        self._current = None
        sender = pending.bus
        queue = self._queues.get(sender)
        if queue is not None and queue.__class__ is TxBuffers:
            tq: TxBuffers = queue                 # typed: native calls (session 17)
            old = tq.head
            tq.sent(pending)                      # its buffer frees; the firmware refills it
            nxt = tq.head
            if nxt is not None:
                self._active[sender] = queue
                if nxt is not old and not self._faulty:
                    _heads_push(self._heads, nxt)
        lost = None
        if self._faulty:
            lost = self._after_success(now_us, pending)

        aid = pending.arbitration_id
        receivers = self._rx_table[aid]
        if receivers is None:
            receivers = self._receivers(aid)
        taps = self._taps
        if receivers or taps:
            data = pending.data
            # the can.Message is built only for a tap or a receiver without _enqueue_frame;
            # a SimBus gets the RxFrame and builds it if and when a program reads the frame
            msg = _rx_message(now_us / 1e6, aid, data, self.channel, True) if taps else None
            for tap in taps:
                tap(msg)
            frame: Optional[RxFrame] = None
            interrupts: list = []
            entry: tuple
            for entry in receivers:
                bus = entry[0]
                enqueue = entry[1]
                enqueue_frame = entry[2]
                if bus is not sender:
                    if lost is not None and bus in lost:
                        continue
                    if enqueue_frame is not None:
                        if frame is None:
                            frame = RxFrame(now_us, aid, data)
                        fire = enqueue_frame(frame)
                    else:
                        if msg is None:
                            msg = _rx_message(now_us / 1e6, aid, data, self.channel, True)
                        fire = enqueue(msg)
                elif getattr(bus, "receive_own_messages", False):
                    fire = enqueue(_rx_message(now_us / 1e6, aid, data, self.channel, False))
                else:
                    continue
                if fire:
                    interrupts.append(entry)
            # Receive interrupts run at the frame's end time, after every receiver has the frame
            # (inline: same time and priority as a separate PRIO_CAN event, one heap operation
            # less). A frame a handler sends now joins the arbitration below. A SimBus's
            # callback is called directly (what its ``_fire`` would do), others' ``_fire``.
            # If a callback changes the table (a handler switching a board's interrupt off or
            # on, a bus detached), the rest go through ``_fire``, which reads each bus's
            # callback as it is then.
            gen = self._rx_table_gen
            for entry in interrupts:
                cb = entry[3]
                if cb is not None and gen == self._rx_table_gen:
                    cb()
                else:
                    entry[0]._fire(now_us)
        self._arbitrate(now_us)

    # -- fault confinement and injection ------------------------------------------------------
    def _match(self, now_us: int, pending, kind: str):
        rng = self.rng
        for rule in self._rules:
            if rule.kind == kind and rule.matches(now_us, pending.bus, pending.arbitration_id, rng):
                return rule
        return None

    def _bit_us(self, bits: int) -> int:
        if self.bitrate == 1_000_000:
            return bits
        return -((-bits * 1_000_000) // self.bitrate)

    def _error_on_wire(self, now_us: int, pending, bits: int) -> None:
        """The frame meets an error: partial frame + error frame on the wire, counters, retry."""
        # error detected somewhere between the first identifier bit and the ACK delimiter
        err_bit = self.rng.randint(2, bits - 12)
        total = err_bit + ERROR_FRAME_BITS
        dur_us = self._bit_us(total)
        self.error_frames += 1
        self.error_bits += total
        self.bits += total
        self._occupy(now_us, dur_us)
        errs = self._errors
        tx = errs[pending.bus]
        tx.tx_errors += 1
        tx.tec += 8
        tx._update_state()
        for bus in self._buses:
            if bus is not pending.bus:
                es = errs[bus]
                if es.state != BUS_OFF:
                    es.rx_errors += 1
                    es.rec += 1
                    es._update_state()
        if tx.state == BUS_OFF:
            q = self._queues[pending.bus]
            tx.dropped_bus_off += 1 + len(q)
            self._npending -= len(q)
            q.clear()
            self._active.pop(pending.bus, None)
            if tx.auto_recover:
                self._start_recovery(tx, now_us + dur_us)
        else:
            tx.retransmissions += 1
            q = self._queues[pending.bus]
            q.appendleft(pending)                                 # automatic retransmission
            self._active[pending.bus] = q
            self._npending += 1
            if tx.state == ERROR_PASSIVE:
                tx.suspend_until_us = now_us + dur_us + self._bit_us(SUSPEND_BITS)
        self.scheduler.call_at(now_us + dur_us, self._arbitrate, PRIO_ARBITRATION, owner=self._owner)
        self._arb_scheduled = True

    def _after_success(self, now_us: int, pending):
        """Counter decrements after a frame completed; returns the receivers that lose it."""
        errs = self._errors
        tx = errs.get(pending.bus)
        if tx is not None and tx.tec:
            tx.tec -= 1
            tx._update_state()
        for bus in self._buses:
            if bus is not pending.bus:
                es = errs[bus]
                if es.rec:
                    es.rec = 127 if es.rec > 127 else es.rec - 1
                    es._update_state()
        if pending.bus in self._babblers.values():
            self._refill_babbler(pending.bus, now_us)
        if not self._rules:
            return None
        rule = self._match(now_us, pending, "loss")
        if rule is None:
            return None
        lost = set(self._buses) if rule.receivers is None else set(rule.receivers)
        for bus in lost:
            es = errs.get(bus)
            if es is not None and bus is not pending.bus:
                es.frames_lost += 1
        return lost

    def _enable_faults(self) -> None:
        self._faulty = True
        self._heads.clear()                  # arbitration scans the non-empty queues from now on

    def inject_errors(self, *, kind: str = "corrupt", ids=None, sender=None, receivers=None,
                      probability: float = 1.0, count: int | None = None, start_us: int | None = None,
                      end_us: int | None = None) -> ErrorRule:
        """Inject a fault on the wire.

        Parameters
        ----------
        kind : {"corrupt", "loss"}
            ``corrupt``: the matching transmission meets an error (bit/stuff/CRC/form error seen
            by every node): error frame, TEC/REC, automatic retransmission.
            ``loss``: the frame completes on the wire but the ``receivers`` (default all) do not
            get it (a receiver that misses a frame without signalling an error).
        ids : iterable of int, optional
            Only frames with these identifiers (default all).
        sender : bus, optional
            Only frames sent by this attached bus (its node).
        receivers : iterable of bus, optional
            ``loss`` only: the receivers that miss the frame.
        probability : float
            Each matching transmission is hit with this probability (drawn from :attr:`rng`,
            seeded by :meth:`seed`; no wall clock).
        count : int, optional
            At most this many hits.
        start_us, end_us : int, optional
            Active window of simulated time (default from now, no end).

        Returns
        -------
        ErrorRule
            The rule (``hits`` counts its effect); :meth:`remove_rule` removes it.

        Raises
        ------
        BusError
            Unknown kind, probability outside [0, 1], a sender/receiver not attached.
        """
        if kind not in ("corrupt", "loss"):
            raise BusError(f"inject_errors: kind must be 'corrupt' or 'loss', got {kind!r}")
        probability = float(probability)
        if not 0.0 <= probability <= 1.0:
            raise BusError(f"inject_errors: probability must be in [0, 1], got {probability}")
        if sender is not None and sender not in self._buses:
            raise BusError(f"inject_errors: sender {sender!r} is not attached to {self.channel!r}")
        if receivers is not None:
            receivers = tuple(receivers)
            for r in receivers:
                if r not in self._buses:
                    raise BusError(f"inject_errors: receiver {r!r} is not attached to {self.channel!r}")
        rule = ErrorRule(kind, None if ids is None else frozenset(int(i) for i in ids), sender,
                         receivers, probability, None if count is None else int(count),
                         self.scheduler.now_us if start_us is None else int(start_us),
                         None if end_us is None else int(end_us))
        self._rules.append(rule)
        self._enable_faults()
        return rule

    def remove_rule(self, rule: ErrorRule) -> None:
        """Stop an injected fault (idempotent)."""
        if rule in self._rules:
            self._rules.remove(rule)

    def seed(self, seed: int) -> None:
        """Seed the network's fault RNG (deterministic runs)."""
        self.rng.seed(int(seed))

    def drive_bus_off(self, bus, *, auto_recover: bool = False) -> ErrorRule:
        """Corrupt every frame ``bus`` sends until it is bus-off (32 transmit errors).

        The rule removes itself once the node is bus-off; with ``auto_recover`` the node then
        starts the 128 × 11 recessive-bit recovery at once (else call :meth:`request_recovery`).
        """
        es = self.error_state(bus)
        es.auto_recover = bool(auto_recover)
        return self.inject_errors(sender=bus, count=max(1, (256 - es.tec + 7) // 8))

    def request_recovery(self, bus) -> None:
        """The controller of ``bus`` is told to leave bus-off (128 × 11 recessive bits)."""
        es = self.error_state(bus)
        if es.state == BUS_OFF and not es.recovery_requested:
            self._start_recovery(es, self.scheduler.now_us)

    def _start_recovery(self, es: NodeErrorState, t_us: int) -> None:
        es.recovery_requested = True
        es._rec_t0 = t_us
        es._rec_busy0 = self.busy_us
        es._rec_frames0 = self.frames
        self.scheduler.call_at(t_us + self._bit_us(RECOVERY_OCCURRENCES * 11),
                               functools.partial(self._check_recovery, es), PRIO_CAN,
                               owner=self._owner)

    def _check_recovery(self, es: NodeErrorState, now_us: int) -> None:
        if es.state != BUS_OFF or not es.recovery_requested:
            return
        # occurrences: completed frames end with 11 recessive bits; idle time 1 per 11 bit times
        idle_us = (now_us - es._rec_t0) - (self.busy_us - es._rec_busy0)
        bit_us = self._bit_us(1)
        occ = (self.frames - es._rec_frames0) + max(0, idle_us) // (11 * bit_us)
        if occ >= RECOVERY_OCCURRENCES:
            es.tec = es.rec = 0
            es.state = ERROR_ACTIVE
            es.recovery_requested = False
            return
        self.scheduler.call_at(now_us + self._bit_us((RECOVERY_OCCURRENCES - occ) * 11),
                               functools.partial(self._check_recovery, es), PRIO_CAN,
                               owner=self._owner)

    def babble(self, arbitration_id: int, data: bytes = bytes(8), *, name: str = "babbler",
               start_us: int | None = None, end_us: int | None = None) -> None:
        """A babbling node: from ``start_us`` to ``end_us`` it sends ``arbitration_id`` back to
        back (a new frame as soon as the last one completes), winning every arbitration against
        higher identifiers. The frames are valid and delivered (receivers' filters apply)."""
        if name in self._babblers:
            raise BusError(f"babble: a babbling node {name!r} already exists")
        node = _InjectedNode(name)
        node._babble = (int(arbitration_id), bytes(data), end_us)
        self.attach(node)
        self._babblers[name] = node
        self._enable_faults()
        t0 = self.scheduler.now_us if start_us is None else int(start_us)
        self.scheduler.call_at(t0, functools.partial(self._refill_babbler, node), PRIO_CAN,
                               owner=self._owner)

    def _refill_babbler(self, node, now_us: int) -> None:
        aid, data, end_us = node._babble
        if node not in self._buses or (end_us is not None and now_us >= end_us):
            return
        if not self._queues[node]:
            self.submit(node, can.Message(arbitration_id=aid, data=data, is_extended_id=False))

    def error_state(self, bus) -> NodeErrorState:
        """The :class:`NodeErrorState` of an attached bus (its TEC/REC registers).

        Raises
        ------
        BusError
            If ``bus`` is not attached.
        """
        es = self._errors.get(bus)
        if es is None:
            raise BusError(f"{bus!r} is not attached to CanNetwork {self.channel!r}")
        return es

    def error_counters(self) -> dict:
        """Per-node fault-confinement counters {node name: NodeErrorState.as_dict()}, in attach
        order; a name used by several buses gets ``#k`` (k = attach index) appended."""
        out = {}
        names = [es.name for es in self._errors.values()]
        for k, es in enumerate(self._errors.values()):
            key = es.name if names.count(es.name) == 1 else f"{es.name}#{k}"
            out[key] = es.as_dict()
        return out

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
    @property
    def per_id(self) -> dict[int, int]:
        """Frames sent per identifier, ``{id: frames}`` in identifier order (identifiers sent)."""
        return {i: n for i, n in enumerate(self._frames_by_id) if n}

    @property
    def max_latency_us(self) -> dict[int, int]:
        """Longest wait from submission to the start of transmission per identifier, µs,
        ``{id: µs}`` in identifier order (identifiers sent)."""
        return {i: v for i, v in enumerate(self._max_latency_by_id) if v >= 0}

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
            "per_id": self.per_id,
            "max_latency_us": self.max_latency_us,
            "pending": self.pending_frames(),
            "error_frames": self.error_frames,
            "error_bits": self.error_bits,
        }

    def __repr__(self) -> str:
        return (f"<CanNetwork {self.channel!r} {self.bitrate} bit/s, {len(self._buses)} buses, "
                f"{self.frames} frames>")
