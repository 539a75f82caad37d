"""The four ASCII logs of paper §5.2: commands, device status, sensor data, errors.

Each log is a plain text file, one record per line, whitespace-separated columns under a ``#``
header naming them with units; time is simulated seconds with microsecond resolution. Lines are
flushed as they are written, so a run that stops on an error keeps everything logged before it.

Whole lines only (issue 11): every file is written through :class:`LineFile`, which hands the
operating system complete lines only and, if a write fails part-way (disk full, read-only file
system, I/O error), truncates the file back to the end of the last complete line and raises
:class:`LogWriteError` naming the file. ``close()`` flushes on every exit path (it is also what
``with`` and the runner's ``finally`` call) and closes every file even if one of them fails.

Strings that come from a scenario or from the bus (names, command details) are sanitised by
:func:`sanitize` before they reach a log: control characters (newline, carriage return, tab,
escape ...) and non-ASCII characters become ``\\xNN`` escapes, so no input can add or split a
line.
"""

from __future__ import annotations

import os
from pathlib import Path

from bus.errors import SchmidtFilError

__all__ = ["HostLogs", "CandumpWriter", "SENSOR_COLUMNS", "LOG_FILES", "CANDUMP_LOG", "LineFile",
           "LogWriteError", "sanitize", "DisplayLog", "DISPLAY_LOG"]


class LogWriteError(SchmidtFilError, OSError):
    """A log file could not be written (disk full, read-only, I/O error); names the file."""


def sanitize(text: object) -> str:
    """``str(text)`` with every character outside printable ASCII (0x20..0x7E) escaped as
    ``\\xNN`` / ``\\uNNNN``, so it cannot add or split a log line."""
    s = str(text)
    if s.isascii() and s.isprintable():
        return s
    return "".join(c if " " <= c <= "~" else (f"\\x{ord(c):02x}" if ord(c) < 256 else f"\\u{ord(c):04x}")
                   for c in s)


class LineFile:
    """An append-only text file written in whole lines.

    Parameters
    ----------
    path : Path
        Created (truncated).
    buffer_bytes : int
        Lines are collected until this many bytes, then written with ``os.write`` (0: every
        line at once, as a line-buffered file).

    Raises
    ------
    LogWriteError
        On opening, or on a failed write: the file is cut back to its last complete line and
        the error names it.
    """

    def __init__(self, path: Path, buffer_bytes: int = 0) -> None:
        self.path = Path(path)
        try:
            self._fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        except OSError as exc:
            raise LogWriteError(exc.errno, f"cannot open log {self.path}: {exc.strerror}") from None
        self._buf: list = []
        self._nbuf = 0
        self._limit = int(buffer_bytes)
        self.committed_bytes = 0      # bytes of complete lines on disk
        self.closed = False
        self.failed: LogWriteError | None = None

    def write_line(self, line: str) -> None:
        """Queue one line (without its newline; must not contain one)."""
        if self.failed is not None:
            raise self.failed
        data = (line + "\n").encode("ascii", "backslashreplace")
        self._buf.append(data)
        self._nbuf += len(data)
        if self._nbuf > self._limit:
            self.flush()

    def flush(self) -> None:
        """Write the queued lines (whole lines only; see the class doc)."""
        if not self._buf or self.closed:
            return
        data = b"".join(self._buf)
        self._buf.clear()
        self._nbuf = 0
        view = memoryview(data)
        done = 0
        try:
            while done < len(data):
                done += os.write(self._fd, view[done:])
        except OSError as exc:
            try:                          # cut back to the last complete line
                os.ftruncate(self._fd, self.committed_bytes)
            except OSError:
                pass
            self.failed = LogWriteError(exc.errno, f"cannot write log {self.path}: {exc.strerror} "
                                        f"(kept {self.committed_bytes} bytes of whole lines)")
            raise self.failed from None
        self.committed_bytes += len(data)

    def close(self) -> None:
        """Flush and close (idempotent); the file is closed even if the flush fails."""
        if self.closed:
            return
        try:
            if self.failed is None:
                self.flush()
        finally:
            self.closed = True
            os.close(self._fd)

#: File names of the four logs.
LOG_FILES = {
    "commands": "commands.log",
    "status": "status.log",
    "sensor": "sensor.log",
    "errors": "errors.log",
}

#: File name of the frame log (Linux ``candump -L`` format).
CANDUMP_LOG = "candump.log"

#: Columns of ``sensor.log`` (per axis ``ra``/``dec``), with units.
SENSOR_COLUMNS = (
    "t_s",
    "ra_mode",
    "ra_setpoint_arcsec_s",
    "ra_rate_arcsec_s",
    "ra_u_duty",
    "ra_qei_counts",
    "ra_current_a_a",
    "ra_current_b_a",
    "ra_pos_counts",
    "dec_mode",
    "dec_setpoint_arcsec_s",
    "dec_rate_arcsec_s",
    "dec_u_duty",
    "dec_qei_counts",
    "dec_current_a_a",
    "dec_current_b_a",
    "dec_pos_counts",
    "focus_halfsteps",
    "focus_lvdt_adc",
)


def _t(t_us: int) -> str:
    return f"{t_us // 1_000_000}.{t_us % 1_000_000:06d}"


class HostLogs:
    """Writer of the four logs into a directory.

    Parameters
    ----------
    out_dir : Path
        Directory; created if missing.
    header : str
        One line written as a comment at the top of every log (scenario name, seed).
    extra_sensor_columns : tuple of str
        ``sensor.log`` columns after :data:`SENSOR_COLUMNS` (issue 12: a network with
        tachometers or auxiliary encoders; none on ``basic``, whose log is unchanged).
    """

    def __init__(self, out_dir: Path, header: str = "", extra_sensor_columns: tuple = ()):
        out_dir.mkdir(parents=True, exist_ok=True)
        self.paths = {k: out_dir / v for k, v in LOG_FILES.items()}
        self._files: dict[str, LineFile] = {}
        try:
            for k, p in self.paths.items():
                self._files[k] = LineFile(p)
        except LogWriteError:
            self.close()
            raise
        header = sanitize(header)
        for k, f in self._files.items():
            f.write_line(f"# schmidt-fil {k} log; {header}")
        self._files["commands"].write_line("# t_s  target  command  detail")
        self._files["status"].write_line("# t_s  node  board  event  detail")
        #: the sensor.log columns: :data:`SENSOR_COLUMNS`, then the maintenance quantities of the
        #: network's tachometers and auxiliary encoders (``host.maintenance.sensor_columns``)
        self.sensor_columns = SENSOR_COLUMNS + tuple(extra_sensor_columns)
        self._files["sensor"].write_line("# " + " ".join(self.sensor_columns))
        self._files["errors"].write_line("# t_s  source  error  detail")
        self.counts = {k: 0 for k in LOG_FILES}

    def command(self, t_us: int, target: str, command: str, detail: str = "") -> None:
        """Log a command sent by the host."""
        self._write("commands", f"{_t(t_us)} {sanitize(target)} {sanitize(command)} {sanitize(detail)}".rstrip())

    def status(self, t_us: int, node: int, board: str, event: str, detail: str = "") -> None:
        """Log a device-status event (heartbeat state change, mode change, limit, fault)."""
        self._write("status", f"{_t(t_us)} {node} {sanitize(board)} {sanitize(event)} {sanitize(detail)}".rstrip())

    def sensor(self, t_us: int, values: tuple) -> None:
        """Log one row of sensor data (columns :data:`SENSOR_COLUMNS` after ``t_s``)."""
        self._write("sensor", _t(t_us) + " " + " ".join(_fmt(v) for v in values))

    def error(self, t_us: int, source: str, error: str, detail: str = "") -> None:
        """Log an error (fault frame, malformed frame, missing board, timeout)."""
        self._write("errors", f"{_t(t_us)} {sanitize(source)} {sanitize(error)} {sanitize(detail)}".rstrip())

    def _write(self, which: str, line: str) -> None:
        self._files[which].write_line(line)
        self.counts[which] += 1

    def close(self) -> None:
        """Flush and close every log (idempotent); all are closed even if one fails, then the
        first :class:`LogWriteError` is raised."""
        first = None
        for f in self._files.values():
            try:
                f.close()
            except LogWriteError as exc:
                first = first or exc
        if first is not None:
            raise first

    def __enter__(self) -> "HostLogs":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class CandumpWriter:
    """Writer of every frame, one line each, in the Linux ``candump -L`` log format
    (``(timestamp) channel ID#DATA``), which ``cantools decode bus/schmidt.dbc`` and can-utils'
    ``canplayer`` read.

    Parameters
    ----------
    path : Path
        The log file (created, truncated).
    channel : str
        Interface name written on each line (``can0``, ``vcan0``).
    """

    def __init__(self, path: Path, channel: str = "can0"):
        self.path = Path(path)
        self.channel = sanitize(channel)
        self.frames = 0
        self._f = LineFile(self.path, buffer_bytes=1 << 16)

    def write(self, msg) -> None:
        """Log one ``can.Message``; its ``timestamp`` [s] is written as it is (simulated time on
        the in-process bus, the kernel's wall-clock time on SocketCAN)."""
        self._f.write_line(f"({msg.timestamp:.6f}) {self.channel} {msg.arbitration_id:03X}#{bytes(msg.data).hex().upper()}")
        self.frames += 1

    def flush(self) -> None:
        """Push the buffered lines to the file (a long-running monitor calls this now and then)."""
        self._f.flush()

    def close(self) -> None:
        """Flush and close (idempotent)."""
        self._f.close()


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)


# -- issue 12, room nodes: the display unit's log ---------------------------------------------------
#: File name of the display unit's log in the run directory.
DISPLAY_LOG = "display.log"


class DisplayLog:
    """What the digital display unit showed: one line per refresh, ``t_s  screen``.

    The display firmware's driver port (:class:`boards.peripherals.CharacterDisplay`) calls
    :meth:`show`; the last screen and the count are kept in memory, and, once :meth:`open` gave
    a file, every screen is written to ``display.log`` (whole lines, buffered).

    Parameters
    ----------
    clock : callable() -> int
        Simulated time, µs (the scheduler's ``now_us``).
    """

    def __init__(self, clock) -> None:
        self.clock = clock
        self.last = ""
        self.lines = 0
        self.path: Path | None = None
        self._f: LineFile | None = None

    def open(self, path: Path) -> None:
        """Start writing to ``path`` (created, truncated) with a header naming the columns."""
        self.path = Path(path)
        self._f = LineFile(self.path, buffer_bytes=1 << 14)
        self._f.write_line("# schmidt-fil display log: one line per display refresh")
        self._f.write_line("# t_s  screen (HA h:m:s, DEC d:m:s, axis rates arcsec/s, axis modes)")

    def show(self, text: str) -> None:
        """One screen written by the display firmware."""
        self.last = text
        self.lines += 1
        if self._f is not None:
            self._f.write_line(f"{_t(self.clock())} {sanitize(text)}")

    def close(self) -> None:
        """Flush and close (idempotent)."""
        if self._f is not None:
            self._f.close()
