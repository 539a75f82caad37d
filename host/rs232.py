"""The RS232 hub of paper §3.4: five serial ports, one per board, receiving telemetry packets.

"These boards are independently connected to an 8 port RS232 hub for PC interfacing. Time
stamped data packets each containing 25 sets of 10 ms samples ... are continuously transferred
to the interfacing PC at a fixed interval of 250 ms on five RS232 serial ports." (§3.4). The
packet layout is :mod:`bus.telemetry` (assumed; docs/protocol.md "RS232 telemetry").

:class:`TelemetryPort` reads one port through the pyserial API subset ``read(n)`` /
``in_waiting`` (a :class:`bus.serial_link.SerialEnd` or a real ``serial.Serial`` opened with
``timeout=0``), finds packets by their sync bytes, checks header and CRC, and hands every good
packet to a sink. Nothing a line can deliver makes it raise: a bad header or CRC is counted and
the parser resynchronises on the next sync pattern; garbage between packets is counted as
discarded bytes; a lost packet shows as a sequence gap; a board reset (sequence back to 0 with an
earlier board time) starts a new time base. :class:`Rs232Hub` groups the five ports and writes
``telemetry.log``.

Time base. Packets carry the board's uptime. The hub maps it to its own clock once per board
"epoch" (first packet, and after each detected board restart): the packet's last byte arrived at
the hub at ``now``; it was written ``wire_time(len)`` earlier, right after its last sample, so
``offset = now − wire_time − t_last_sample``. With the emulator's receive callback (fired when
the last byte arrives, no OS latency) the offset is exact; on a polled real port it is late by
up to one poll period, a constant for the epoch.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable, TextIO

from bus import telemetry as T
from bus.scheduler import Scheduler

__all__ = ["TelemetryPort", "Rs232Hub", "TELEMETRY_LOG", "LOG_COLUMNS"]

TELEMETRY_LOG = "telemetry.log"
_SYNC0, _SYNC1 = T.SYNC[0], T.SYNC[1]
_MAX_PACKET = max(T.packet_size(d) for d in T.SAMPLE_FIELDS)
_U32 = 1 << 32
_U16 = 1 << 16

_KIND = {T.DEVICE_AXIS: "axis", T.DEVICE_READER: "reader", T.DEVICE_FOCUS: "focus"}
#: telemetry.log columns after ``t_s board board_t_s seq``, per device type (raw counts).
LOG_COLUMNS = {d: tuple(name for name, _, _ in fields) for d, fields in T.SAMPLE_FIELDS.items()}


class TelemetryPort:
    """Packet receiver on one serial port.

    Parameters
    ----------
    port : object
        pyserial-like: ``read(size) -> bytes`` and ``in_waiting``; with ``timeout = 0`` semantics
        (never blocks).
    board : str
        Board name on this port (``"ra-axis"``); used in the log.
    node : int
        CAN node id of that board: a header naming another node is rejected.
    baud : int
        Line rate, baud (for the wire time in the time-base estimate).
    now_us : callable
        The host's clock, µs.
    sink : callable, optional
        ``sink(port, seq, t0_us, period_us, buf, offset)`` for every good packet: sequence
        number, board time of sample 0 (unwrapped, µs), sample spacing, and the receive buffer
        with the payload at ``offset`` (valid during the call only; :meth:`unpack` decodes it
        — done only when needed, so a hub without a log does not pay for it). The board→host
        time offset is :attr:`offset_us`.

    Attributes
    ----------
    packets : int
        Good packets.
    crc_errors : int
        Packets with a plausible header whose CRC failed (corrupt or truncated).
    header_errors : int
        Sync patterns followed by an implausible header.
    discarded_bytes : int
        Bytes skipped while hunting for a sync pattern (garbage, or a packet whose sync was hit).
    seq_gaps : int
        Packets missing according to the sequence counter (sum of the gaps).
    restarts : int
        Board restarts seen (sequence back to 0 with an earlier board time).
    """

    def __init__(self, port, board: str, node: int, baud: int, now_us: Callable[[], int],
                 sink: Callable | None = None) -> None:
        self.port = port
        self.board = board
        self.node = int(node)
        self.device_type = T.DEVICE_OF_NODE[self.node]
        self.baud = int(baud)
        self.now_us = now_us
        self.sink = sink
        self._buf = bytearray()
        self._size = T.packet_size(self.device_type)
        self._payload = T.payload_struct(self.device_type)
        self._wire_us = T.wire_time_us(self._size, self.baud)
        self._last_seq: int | None = None
        self._last_t0 = 0           # board time of the last packet's first sample, unwrapped µs
        self._wraps = 0
        self.offset_us: int | None = None
        self.packets = self.crc_errors = self.header_errors = 0
        self.discarded_bytes = self.seq_gaps = self.restarts = 0

    def counters(self) -> dict:
        """Per-port counters (for the report)."""
        return {"packets": self.packets, "crc_errors": self.crc_errors,
                "header_errors": self.header_errors, "discarded_bytes": self.discarded_bytes,
                "seq_gaps": self.seq_gaps, "restarts": self.restarts,
                "pending_bytes": len(self._buf)}

    def poll(self, *_args) -> int:
        """Read what has arrived and process every complete packet; returns good packets."""
        n = self.port.in_waiting
        if n:
            self._buf += self.port.read(n)
        return self.feed()

    def feed(self, data: bytes = b"") -> int:
        """Append ``data`` and parse; returns good packets found. Never raises on line data."""
        buf = self._buf
        if data:
            buf += data
        good = 0
        i = 0
        n = len(buf)
        size = self._size
        while True:
            j = buf.find(T.SYNC, i)
            if j < 0:
                # keep a trailing first sync byte: its partner may come with the next read
                keep = n - 1 if n and buf[-1] == _SYNC0 else n
                self.discarded_bytes += max(0, keep - i)
                i = max(i, keep)
                break
            if j > i:
                self.discarded_bytes += j - i
                i = j
            if n - i < T.HEADER_SIZE:
                break                       # wait for the rest of the header
            h = T.check_header(buf, i, self.node)
            if h is None:
                self.header_errors += 1
                self.discarded_bytes += 2
                i += 2
                continue
            if n - i < size:
                break                       # wait for the rest of the packet
            end = i + size
            crc = buf[end - 2] | (buf[end - 1] << 8)
            if crc != T.crc16(buf[i + 2:end - 2]):
                self.crc_errors += 1
                self.discarded_bytes += 2
                i += 2
                continue
            self._accept(h, buf, i + T.HEADER_SIZE)
            good += 1
            i = end
        if i:
            del buf[:i]
        return good

    def _accept(self, h: tuple, buf: bytearray, offset: int) -> None:
        _, _, _, _, seq, t0, period = h
        t0 += self._wraps * _U32
        restart = False
        if self._last_seq is not None:
            gap = (seq - self._last_seq - 1) % _U16
            if seq == 0 and self._last_seq != 0xFFFF:
                restart = True              # boards restart their packet counter at 0
            elif t0 <= self._last_t0:
                if gap < 1000:
                    self._wraps += 1        # u32 µs board clock wrapped (every 4295 s)
                    t0 += _U32
                else:
                    restart = True          # a reboot whose first packets were lost
            if restart:
                self.restarts += 1
            else:
                self.seq_gaps += gap
        if self.offset_us is None or restart:
            self._wraps = 0
            t0 = h[5]
            t_last = t0 + (T.SAMPLES_PER_PACKET - 1) * period
            self.offset_us = self.now_us() - self._wire_us - t_last
        self._last_seq, self._last_t0 = seq, t0
        self.packets += 1
        if self.sink is not None:
            self.sink(self, seq, t0, period, buf, offset)

    def unpack(self, buf, offset: int) -> tuple:
        """The samples' fields, flat (sample after sample), from a packet payload at ``offset``."""
        return self._payload.unpack_from(buf, offset)


class Rs232Hub:
    """The PC's 8-port RS232 hub with the five boards' ports (paper §3.4).

    Parameters
    ----------
    scheduler : Scheduler
        The host's clock.
    baud : int
        Line rate of every port, baud.

    Notes
    -----
    ``telemetry.log``: ASCII, one line per 10 ms sample: ``t_s board board_t_s seq`` then the
    board's raw fields (:data:`LOG_COLUMNS`; units and scaling in docs/protocol.md). ``t_s`` is
    the hub's time of the sample (board time + the epoch offset, see module doc), ``board_t_s``
    the board's own uptime. Lines of different boards interleave in arrival order (per board
    they are in time order).
    """

    def __init__(self, scheduler: Scheduler, baud: int) -> None:
        self.scheduler = scheduler
        self.baud = int(baud)
        self.ports: dict[str, TelemetryPort] = {}
        self.samples = 0
        self._log: TextIO | None = None
        self.log_path: Path | None = None

    def open_log(self, path: Path) -> None:
        """Start writing ``telemetry.log`` at ``path`` (without a log, packets are still checked
        and counted)."""
        self.log_path = path
        self._log = path.open("w", encoding="ascii", buffering=1 << 16)
        self._log.write("# schmidt-fil telemetry log (RS232, paper sec. 3.4); packet layout: docs/protocol.md\n")
        self._log.write("# t_s: hub time of the sample; board_t_s: board uptime; seq: packet counter\n")
        for d, cols in LOG_COLUMNS.items():
            self._log.write(f"# {_KIND[d]}: t_s board board_t_s seq " + " ".join(cols) + "\n")

    def add_port(self, port, board: str, node: int) -> TelemetryPort:
        """Attach a board's serial port; uses its receive callback when it has one, otherwise
        the owner must call :meth:`poll`."""
        tp = TelemetryPort(port, board, node, self.baud, lambda: self.scheduler.now_us, self._sink)
        self.ports[board] = tp
        if hasattr(port, "set_rx_callback"):
            port.set_rx_callback(tp.poll)
        return tp

    def poll(self) -> None:
        """Read every port (for ports without a receive callback)."""
        for tp in self.ports.values():
            tp.poll()

    def _sink(self, tp: TelemetryPort, seq: int, t0: int, period: int, buf, offset: int) -> None:
        self.samples += T.SAMPLES_PER_PACKET
        log = self._log
        if log is None:
            return
        flat = tp.unpack(buf, offset)
        offset_us = tp.offset_us
        k = len(LOG_COLUMNS[tp.device_type])
        board = tp.board
        lines = []
        for i in range(T.SAMPLES_PER_PACKET):
            tb = t0 + i * period
            th = tb + offset_us
            vals = " ".join(map(str, flat[i * k:(i + 1) * k]))
            lines.append(f"{th // 1_000_000}.{th % 1_000_000:06d} {board} "
                         f"{tb // 1_000_000}.{tb % 1_000_000:06d} {seq} {vals}\n")
        log.write("".join(lines))

    def counters(self) -> dict:
        """Per-board port counters plus the total of samples received."""
        return {"baud": self.baud, "samples": self.samples,
                "ports": {name: tp.counters() for name, tp in self.ports.items()}}

    def close(self) -> None:
        """Read what is left, close the log (idempotent)."""
        if self._log is not None and not self._log.closed:
            self._log.close()
