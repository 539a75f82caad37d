"""Logs never lose a line: whole lines on a full disk, the file named, scenario strings sanitised."""

import subprocess
import sys
import textwrap
from pathlib import Path

from host.logs import HostLogs, sanitize

ROOT = Path(__file__).resolve().parents[1]


def test_full_disk_keeps_whole_lines_and_the_error_names_the_file(tmp_path):
    """A file-size limit (the kernel's EFBIG, like ENOSPC) mid-write: the candump log ends with a
    complete line, and the one-line error names the file."""
    code = textwrap.dedent(f"""
        import resource, signal, sys
        import can
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (100_000, 100_000))
        from host.logs import CandumpWriter
        w = CandumpWriter(__import__("pathlib").Path({str(tmp_path / 'candump.log')!r}))
        try:
            for i in range(100_000):
                w.write(can.Message(timestamp=i * 1e-4, arbitration_id=0x181, data=bytes(8),
                                    is_extended_id=False))
            w.close()
        except Exception as exc:
            try:
                w.close()
            except Exception:
                pass
            print(type(exc).__name__, exc)
            sys.exit(3)
    """)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 3, r.stderr
    assert str(tmp_path / "candump.log") in r.stdout
    data = (tmp_path / "candump.log").read_bytes()
    assert 0 < len(data) <= 100_000 and data.endswith(b"\n")
    for line in data.decode().splitlines():
        assert line.endswith(" can0 181#0000000000000000") and line.startswith("(")


def test_a_newline_in_the_scenario_name_cannot_inject_a_line(tmp_path):
    """A header or detail with newline/CR/escape characters stays one line in every log."""
    evil = "demo\n0.000000 ra-axis FAKE injected\r\x1b[2J"
    logs = HostLogs(tmp_path, header=f"scenario {evil}")
    logs.command(5, "ra-axis", "SLEW", evil)
    logs.error(6, evil, "bad", evil)
    logs.close()
    for name in ("commands.log", "status.log", "sensor.log", "errors.log"):
        lines = (tmp_path / name).read_text(encoding="ascii").splitlines()
        assert all(l.startswith("#") or l[0].isdigit() for l in lines), name
        assert not any("FAKE" in l and not l.startswith("#") and "\\x0a" not in l for l in lines)
    assert len((tmp_path / "errors.log").read_text().splitlines()) == 3


def test_sanitize_keeps_printable_ascii_and_escapes_the_rest():
    """Printable ASCII unchanged; control and non-ASCII characters escaped."""
    assert sanitize("RA slew 2 deg/s") == "RA slew 2 deg/s"
    assert sanitize("a\nb\té") == "a\\x0ab\\x09\\xe9"
