"""The four ASCII logs of paper §5.2: commands, device status, sensor data, errors.

Each log is a plain text file, one record per line, whitespace-separated columns under a ``#``
header naming them with units; time is simulated seconds with microsecond resolution. Lines are
flushed as they are written, so a run that stops on an error keeps everything logged before it.
"""

from __future__ import annotations

from pathlib import Path
from typing import TextIO

__all__ = ["HostLogs", "CandumpWriter", "SENSOR_COLUMNS", "LOG_FILES", "CANDUMP_LOG"]

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
    """

    def __init__(self, out_dir: Path, header: str = ""):
        out_dir.mkdir(parents=True, exist_ok=True)
        self.paths = {k: out_dir / v for k, v in LOG_FILES.items()}
        self._files: dict[str, TextIO] = {
            k: p.open("w", encoding="ascii", errors="replace", buffering=1) for k, p in self.paths.items()
        }
        for k, f in self._files.items():
            f.write(f"# schmidt-fil {k} log; {header}\n")
        self._files["commands"].write("# t_s  target  command  detail\n")
        self._files["status"].write("# t_s  node  board  event  detail\n")
        self._files["sensor"].write("# " + " ".join(SENSOR_COLUMNS) + "\n")
        self._files["errors"].write("# t_s  source  error  detail\n")
        self.counts = {k: 0 for k in LOG_FILES}

    def command(self, t_us: int, target: str, command: str, detail: str = "") -> None:
        """Log a command sent by the host."""
        self._write("commands", f"{_t(t_us)} {target} {command} {detail}".rstrip())

    def status(self, t_us: int, node: int, board: str, event: str, detail: str = "") -> None:
        """Log a device-status event (heartbeat state change, mode change, limit, fault)."""
        self._write("status", f"{_t(t_us)} {node} {board} {event} {detail}".rstrip())

    def sensor(self, t_us: int, values: tuple) -> None:
        """Log one row of sensor data (columns :data:`SENSOR_COLUMNS` after ``t_s``)."""
        self._write("sensor", _t(t_us) + " " + " ".join(_fmt(v) for v in values))

    def error(self, t_us: int, source: str, error: str, detail: str = "") -> None:
        """Log an error (fault frame, malformed frame, missing board, timeout)."""
        self._write("errors", f"{_t(t_us)} {source} {error} {detail}".rstrip())

    def _write(self, which: str, line: str) -> None:
        self._files[which].write(line + "\n")
        self.counts[which] += 1

    def close(self) -> None:
        """Flush and close every log (idempotent)."""
        for f in self._files.values():
            if not f.closed:
                f.close()

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
        self.channel = channel
        self.frames = 0
        self._f = self.path.open("w", encoding="ascii", buffering=1 << 16)

    def write(self, msg) -> None:
        """Log one ``can.Message``; its ``timestamp`` [s] is written as it is (simulated time on
        the in-process bus, the kernel's wall-clock time on SocketCAN)."""
        self._f.write(f"({msg.timestamp:.6f}) {self.channel} {msg.arbitration_id:03X}#{bytes(msg.data).hex().upper()}\n")
        self.frames += 1

    def flush(self) -> None:
        """Push the buffered lines to the file (a long-running monitor calls this now and then)."""
        if not self._f.closed:
            self._f.flush()

    def close(self) -> None:
        """Flush and close (idempotent)."""
        if not self._f.closed:
            self._f.close()


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)
