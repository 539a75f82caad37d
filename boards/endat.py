"""EnDat-2.2-style position transfer between the PIC18F4480 reader and the RCN 829 encoder.

The paper (§3.2-§3.3) says the 29-bit Heidenhain RCN 829 on the axis shaft is read over the
bidirectional EnDat 2.2 interface through the PIC's synchronous serial port. This module models
the *bit frame* of one "encoder send position values" exchange, not the clock-level timing:

master → encoder: mode command, 6 bits ``000111`` (mode bits and their complement)
encoder → master: start bit S = 1, error bits F1 and F2 (F2 is the EnDat 2.2 second alarm bit,
F1 = alarm, both 0 when healthy), the 29 position bits **LSB first**, then 5 CRC bits.

CRC (what "EnDat-2.2-style" means here)
---------------------------------------
Heidenhain's specification is not public. The CRC used is a 5-bit CRC with generator
polynomial G(x) = x^5 + x^3 + x + 1 (0x0B), shift register preset to all ones (0x1F), fed with
F1, F2 and the position bits in transmission order, and sent most-significant bit first and
complemented. The generator is the one read off the shift-register circuit of the EnDat
specification in the mikrocontroller.net thread "CRC Polynom für EnDAT Encoder"
(https://www.mikrocontroller.net/topic/515706: "Bits 0, 1 und 3 werden mit XOR verknüpft ...
0xB ... Register mit Einsen vorgeladen"); Heidenhain's FAQ confirms the 5-bit CRC covers the
error bit and that "all one-bit errors ... can be detected". The final complement is our
assumption. G(x) = (x + 1)(x^4 + x^3 + 1) has the factor x + 1, so every odd number of flipped
bits is detected as well.
"""

from __future__ import annotations

from typing import Callable, Final, List, NamedTuple, Optional, Sequence

__all__ = [
    "CRC_POLY",
    "CRC_BITS",
    "MODE_SEND_POSITION",
    "POSITION_BITS",
    "crc5",
    "crc5_word",
    "build_position_frame",
    "parse_position_frame",
    "build_position_word",
    "parse_position_word",
    "EnDatReading",
    "EnDatEncoder",
    "EnDatMaster",
]

CRC_POLY: Final = 0x0B          # x^5 + x^3 + x + 1 (x^5 implicit)
CRC_BITS: Final = 5
CRC_PRESET: Final = 0x1F
MODE_SEND_POSITION: Final = 0b000111   # EnDat "encoder send position values" (mode bits + complement)
POSITION_BITS: Final = 29              # RCN 829, §3.2


def frame_bits(position_bits: int = POSITION_BITS) -> int:
    """Bits of one position frame: start bit, 2 alarm bits, the position, the CRC."""
    return 1 + 2 + position_bits + CRC_BITS


#: Bits of the RCN 829's position frame (37).
FRAME_BITS: Final = frame_bits()


def crc5(bits: Sequence[int]) -> int:
    """EnDat-2.2-style 5-bit CRC of a bit sequence (in transmission order).

    Parameters
    ----------
    bits : sequence of int
        The bits covered by the CRC (F1, F2, position LSB first), each 0 or 1.

    Returns
    -------
    int
        The CRC as transmitted, 0..31 (bit 4 sent first), i.e. the complemented register.
    """
    return (~_crc_register(bits, CRC_PRESET)) & 0x1F


def _crc_register(bits: Sequence[int], preset: int) -> int:
    reg = preset
    for b in bits:
        fb = ((reg >> 4) & 1) ^ (b & 1)
        reg = (reg << 1) & 0x1F
        if fb:
            reg ^= CRC_POLY
    return reg


_CRC_TABLES: Final[dict] = {}


def _crc_tables(nbits: int) -> tuple:
    """Per-byte tables of the CRC register for an ``nbits``-bit message (built once per length).

    The register update is linear over GF(2) in (register, message bit), so the final register is
    the preset's contribution XOR the contributions of the set message bits; the tables hold
    those contributions byte by byte (bit i of byte j = message bit 8j + i).
    """
    t = _CRC_TABLES.get(nbits)
    if t is None:
        base = _crc_register([0] * nbits, CRC_PRESET)
        cols = []
        for i in range(nbits):
            unit = [0] * nbits
            unit[i] = 1
            cols.append(_crc_register(unit, 0))
        tables = []
        for j in range(0, nbits, 8):
            row = []
            for byte in range(256):
                r = 0
                for k in range(8):
                    if byte >> k & 1 and j + k < nbits:
                        r ^= cols[j + k]
                row.append(r)
            tables.append(row)
        t = _CRC_TABLES[nbits] = (base, tuple(tuple(r) for r in tables))
    return t


def crc5_word(word: int, nbits: int) -> int:
    """:func:`crc5` of an ``nbits``-bit message held in an int (bit i = the i-th bit sent).

    Table-driven (a few lookups instead of one loop pass per bit); equal to ``crc5`` of the same
    bits for every message (``tests/test_boards_endat.py``).

    Parameters
    ----------
    word : int
        Message bits, bit 0 transmitted first.
    nbits : int
        Message length (31 for F1, F2 and a 29-bit position).

    Returns
    -------
    int
        The CRC as transmitted, 0..31, i.e. the complemented register.
    """
    base, tables = _crc_tables(nbits)
    reg = base
    for row in tables:
        reg ^= row[word & 0xFF]
        word >>= 8
    return (~reg) & 0x1F


#: 5-bit reversal: the CRC is sent MSB first, the frame word holds bit i = i-th bit sent
_REV5: Final = tuple(int(f"{v:05b}"[::-1], 2) for v in range(32))


def build_position_word(position: int, *, f1: int = 0, f2: int = 0,
                        position_bits: int = POSITION_BITS) -> int:
    """:func:`build_position_frame` as an int shift register: bit k = the k-th bit sent.

    The reader's fast path (no per-bit Python loop); ``build_position_frame`` returns the same
    frame as a bit list.
    """
    payload = (f1 & 1) | (f2 & 1) << 1 | (position & ((1 << position_bits) - 1)) << 2
    n = 2 + position_bits
    return 1 | payload << 1 | _REV5[crc5_word(payload, n)] << (n + 1)


def parse_position_word(frame: int, nbits: int, position_bits: int = POSITION_BITS) -> "EnDatReading":
    """:func:`parse_position_frame` of a frame held in an int (bit k = the k-th bit sent).

    Never raises for a corrupted frame: a missing start bit, a wrong length or a CRC mismatch
    give ``position=None``.
    """
    n = 2 + position_bits
    if nbits != n + 1 + CRC_BITS or not frame & 1:
        return _NO_START
    payload = (frame >> 1) & ((1 << n) - 1)
    f1, f2 = payload & 1, (payload >> 1) & 1
    if crc5_word(payload, n) != _REV5[(frame >> (n + 1)) & 0x1F]:
        return _tuple_new(EnDatReading, (None, False, f1, f2, True))
    return _tuple_new(EnDatReading, (payload >> 2, True, f1, f2, True))


def word_to_bits(frame: int, nbits: int) -> List[int]:
    """The bit list (transmission order) of a frame held in an int."""
    return [(frame >> k) & 1 for k in range(nbits)]


def build_position_frame(position: int, *, f1: int = 0, f2: int = 0,
                         position_bits: int = POSITION_BITS) -> List[int]:
    """Encoder's answer to ``MODE_SEND_POSITION`` as a bit list.

    Layout: ``[S, F1, F2, p0 .. p(n-1), c4 .. c0]`` (37 bits for n = 29).

    Parameters
    ----------
    position : int
        Raw position word, 0 .. 2**position_bits − 1 (masked).
    f1, f2 : int
        Error bits (0 healthy).
    position_bits : int
        Position word width (29).
    """
    position &= (1 << position_bits) - 1
    payload = [f1 & 1, f2 & 1] + [(position >> i) & 1 for i in range(position_bits)]
    crc = crc5(payload)
    return [1] + payload + [(crc >> (CRC_BITS - 1 - i)) & 1 for i in range(CRC_BITS)]


class EnDatReading(NamedTuple):
    """Result of one position exchange (immutable).

    Attributes
    ----------
    position : int or None
        Decoded raw position (counts, 2**29 per rev), None when the frame is unusable.
    crc_ok : bool
        CRC matched (False also when the start bit was missing).
    f1, f2 : int
        Error bits as received.
    start_ok : bool
        A start bit was seen.

    A ``NamedTuple`` (not a frozen dataclass): the readers build one per exchange, and
    ``tuple.__new__`` builds it without a Python-level ``__init__`` (session 16, issue 12).
    """

    position: Optional[int]
    crc_ok: bool
    f1: int = 0
    f2: int = 0
    start_ok: bool = True

    @property
    def valid(self) -> bool:
        """Usable: start bit, CRC good and no encoder alarm."""
        return self.start_ok and self.crc_ok and not self.f1 and not self.f2


#: ``tuple.__new__(EnDatReading, values)``: built without the NamedTuple's Python-level ``__new__``
_tuple_new: Final = tuple.__new__
#: the reading of a frame without its start bit (or of the wrong length)
_NO_START: Final = EnDatReading(None, False, 0, 0, False)


def parse_position_frame(bits: Sequence[int], position_bits: int = POSITION_BITS) -> EnDatReading:
    """Check and decode a frame produced by :func:`build_position_frame`.

    Never raises for a corrupted frame: a missing start bit, a wrong length or a CRC mismatch
    give ``position=None``.
    """
    n = 1 + 2 + position_bits + CRC_BITS
    if len(bits) != n or bits[0] != 1:
        return EnDatReading(None, False, start_ok=False)
    payload = list(bits[1:3 + position_bits])
    crc_rx = 0
    for b in bits[3 + position_bits:]:
        crc_rx = (crc_rx << 1) | (b & 1)
    f1, f2 = payload[0], payload[1]
    if crc5(payload) != crc_rx:
        return EnDatReading(None, False, f1, f2)
    pos = 0
    for i, b in enumerate(payload[2:]):
        pos |= (b & 1) << i
    return EnDatReading(pos, True, f1, f2)


class EnDatEncoder:
    """Encoder side of the exchange: builds the bit frame from the position port.

    Parameters
    ----------
    read_position_word : callable
        Port returning the raw 29-bit absolute position (counts, 0 .. 2**29 − 1).
    position_bits : int
        Word width (29).

    Notes
    -----
    Fault injection for tests and scenarios: :meth:`flip_bit` inverts bit ``n`` of the *next*
    frame (0 = start bit, 1 = F1, 2 = F2, 3.. = position LSB first, last 5 = CRC);
    :attr:`alarm` sets F1 on every frame (an encoder malfunction).
    """

    def __init__(self, read_position_word: Callable[[], int],
                 position_bits: int = POSITION_BITS) -> None:
        self.read_position_word = read_position_word
        self.position_bits = position_bits
        self.frame_bits = frame_bits(position_bits)
        self._flip_mask = 0       # bits to invert in the next frame (fault injection)
        self.alarm = False

    def flip_bit(self, n: int) -> None:
        """Invert bit ``n`` (0 .. frame_bits − 1) of the next transmitted frame (one shot)."""
        if not 0 <= n < self.frame_bits:
            raise ValueError(f"bit index must be 0..{self.frame_bits - 1}, got {n}")
        self._flip_mask ^= 1 << n

    def respond_word(self, mode_command: int) -> int:
        """Answer a mode command with a frame held in an int (bit k = the k-th bit sent).

        An unknown mode gets no start bit (all zeros). Pending bit flips are applied once.
        """
        if mode_command != MODE_SEND_POSITION:
            return 0
        frame = build_position_word(int(self.read_position_word()), f1=int(self.alarm),
                                    position_bits=self.position_bits) ^ self._flip_mask
        self._flip_mask = 0
        return frame

    def respond(self, mode_command: int) -> List[int]:
        """:meth:`respond_word` as a bit list (transmission order)."""
        return word_to_bits(self.respond_word(mode_command), self.frame_bits)


class EnDatMaster:
    """EnDat master peripheral of the PIC18F4480 (synchronous serial port + firmware framing).

    Parameters
    ----------
    read_position_word : callable
        Port returning the encoder's raw 29-bit position word (counts).
    position_bits : int
        Word width (29, RCN 829).

    Attributes
    ----------
    encoder : EnDatEncoder
        The encoder model at the far end of the cable (fault injection lives there).
    crc_errors : int
        Frames rejected (CRC mismatch or missing start bit) since reset.
    alarms : int
        Frames with F1/F2 set.
    reads : int
        Exchanges performed.
    """

    def __init__(self, read_position_word: Callable[[], int],
                 position_bits: int = POSITION_BITS) -> None:
        self.encoder = EnDatEncoder(read_position_word, position_bits)
        self.position_bits = position_bits
        self.crc_errors = 0
        self.alarms = 0
        self.reads = 0
        self._last_word = 0

    @property
    def last_frame(self) -> List[int]:
        """The last frame received, as a bit list (transmission order); empty before any read."""
        return word_to_bits(self._last_word, self.encoder.frame_bits) if self.reads else []

    def flip_bit(self, n: int) -> None:
        """Fault injection: corrupt bit ``n`` of the next frame (see :class:`EnDatEncoder`)."""
        self.encoder.flip_bit(n)

    def read(self) -> EnDatReading:
        """Perform one exchange; counts CRC errors and alarms. Never raises on a bad frame."""
        self.reads += 1
        frame = self.encoder.respond_word(MODE_SEND_POSITION)
        self._last_word = frame
        r = parse_position_word(frame, self.encoder.frame_bits, self.position_bits)
        if not r.crc_ok:
            self.crc_errors += 1
        elif r.f1 or r.f2:
            self.alarms += 1
        return r

    def reset(self) -> None:
        """Power-on: counters zero (pending fault injections at the encoder are kept)."""
        self.crc_errors = 0
        self.alarms = 0
        self.reads = 0
        self._last_word = 0
