"""The ``schmidt-fil`` command: one entry point, one module per subcommand.

Each subcommand module has ``add_subparser(subparsers)`` registering its parser with
``func=run``; ``run(args) -> int`` returns the exit status. Errors print one line (file, line,
key or board and simulated time) unless ``--debug`` is given, as cantools does.
"""

from __future__ import annotations

import argparse
import importlib
import signal
import threading
import sys

#: Subcommand modules, in help order.
SUBCOMMANDS = ("host.cli_run", "host.cli_serve", "host.cli_bench", "host.cli_calibrate", "host.cli_benchmark",
               "host.cli_validate", "host.cli_identify_mesh", "host.cli_validate_paper", "host.cli_fuzz", "host.cli_conform")


def build_parser() -> argparse.ArgumentParser:
    """Return the top-level parser with every available subcommand registered."""
    parser = argparse.ArgumentParser(
        prog="schmidt-fil",
        description="Firmware-in-the-loop emulator of the ARIES 50/80 cm Schmidt telescope control network.",
    )
    parser.add_argument("--debug", action="store_true", help="show full tracebacks")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in SUBCOMMANDS:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name == name:
                continue
            raise
        module.add_subparser(sub)
    return parser


class Terminated(KeyboardInterrupt):
    """SIGTERM, handled like SIGINT: the run stops where it is, every log is closed in whole
    lines (``finally`` blocks run), exit status 143."""


def _on_sigterm(signum, frame) -> None:
    raise Terminated()


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the process exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    previous = None
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        return int(args.func(args) or 0)
    except Terminated:
        print("schmidt-fil: terminated (SIGTERM); logs closed", file=sys.stderr)
        return 143
    except KeyboardInterrupt:
        print("schmidt-fil: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # one line unless --debug
        if args.debug:
            raise
        from bus.errors import SchmidtFilError

        kind = "error" if isinstance(exc, (SchmidtFilError, OSError, ValueError)) else type(exc).__name__
        print(f"schmidt-fil: {kind}: {exc}", file=sys.stderr)
        return 1
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
