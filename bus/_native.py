"""Which modules run compiled (mypyc), and the run-time switch back to their Python source.

The hot path of the emulator (docs/performance.md, "Compiled hot path") is compiled by mypyc at
install time (``setup.py`` reads :data:`NATIVE_MODULES` from this file). The ``.py`` source stays
the reference: a compiled module and its source give the same results (the test suite runs on
the compiled build in CI, and ``tests/test_native.py`` runs a scenario both ways and compares
the logs).

``SCHMIDT_FIL_NATIVE=0`` in the environment makes Python import the ``.py`` source of these
modules instead of their compiled extensions, for debugging (tracebacks with source lines,
pdb) or to measure what the compilation gives, without reinstalling. The switch acts at import,
so it must be set before ``bus`` or ``boards`` is first imported. The source also runs, with a
one-line warning, when a listed ``.py`` is newer than its compiled extension (edited or checked
out after the install), so an edit always takes effect.

This file must stay importable on its own (``setup.py`` runs it before the package's
dependencies are installed): standard library only.
"""

from __future__ import annotations

import importlib.machinery
import importlib.util
import os
import sys

__all__ = ["NATIVE_MODULES", "native_modules", "install_source_finder", "own_abc_cache", "stale_modules"]

#: Dotted names of the modules compiled at install (on the per-frame path of every simulated
#: second: measured with the per-event profile of docs/performance.md). ``bus.protocol`` is
#: compiled with its public codecs' arguments typed ``Any`` (``_Int``): they validate any input
#: type themselves and name the frame and field, where an ``int`` annotation would refuse a float
#: or a numpy integer with a bare ``TypeError`` first. Not compiled on purpose:
#: ``boards.services.device`` and the other canopen services (tests replace their methods to
#: build broken boards, which compiled callers would not see); only their PDO gate
#: (``boards.services.pdo``) and the application glue are.
NATIVE_MODULES = (
    "bus.scheduler",
    "bus.network",
    "bus.usb_link",
    "bus.hid_reports",
    "boards.peripherals",
    "boards.services.application",
    "boards.services.pdo",
    "boards.firmware_base",
    "boards.usb_gateway",
    "boards.tachometer",
    "boards.velocity_reader",
    "boards.control",
    "boards.safety",
    "boards.endat",
    "boards.axis_controller",
    "boards.position_reader",
    "boards.aux_encoder",
    "boards.focus_controller",
    "boards.display",
    "boards.dome",
    "boards.weather",
    "host.client",
    "host.hid_device",
    "host.gateway_bus",
    "bus.simbus",
    "bus.protocol",
    "boards.usb_hid",
    "host.ports",
    "plant.axis",
)


#: Group name of the mypyc build: its shared library is ``<GROUP>__mypyc<suffix>`` in the folder
#: holding ``bus/`` (each listed module's own extension is a small shim that loads it).
GROUP = "schmidt_fil"


def own_abc_cache(cls: type) -> type:
    """Give an ABC subclass compiled by mypyc its own ABC caches (returns ``cls``).

    mypyc (2.x) builds a class that derives from an ABC (python-can's ``BusABC``) without running
    ``ABCMeta.__new__``'s cache set-up, so the class shares its base's ``_abc_impl``: once
    ``isinstance(a SimBus, can.BusABC)`` had been asked, ``isinstance(a SimBus, HidGatewayBus)``
    answered True (found by tests/test_usb_gateway_host.py). Called on ``bus.simbus.SimBus`` and
    ``host.gateway_bus.HidGatewayBus`` right after their definition; a no-op on the source.
    Uses CPython's ``abc._abc_init`` (mypyc builds for CPython only).
    """
    if "_abc_impl" not in cls.__dict__:
        import abc

        abc._abc_init(cls)  # type: ignore[attr-defined]
    return cls


def native_modules() -> list:
    """Names of the :data:`NATIVE_MODULES` imported now from a compiled extension (list of str)."""
    out = []
    for name in NATIVE_MODULES:
        mod = sys.modules.get(name)
        if mod is not None and not str(getattr(mod, "__file__", "")).endswith(".py"):
            out.append(name)
    return out


class _SourceFinder:
    """Meta path finder: the ``.py`` source of a :data:`NATIVE_MODULES` module, never its
    compiled extension (installed by :func:`install_source_finder`)."""

    @classmethod
    def find_spec(cls, fullname, path=None, target=None):
        if fullname not in NATIVE_MODULES or not path:
            return None
        leaf = fullname.rpartition(".")[2] + ".py"
        for entry in path:
            candidate = os.path.join(entry, leaf)
            if os.path.isfile(candidate):
                loader = importlib.machinery.SourceFileLoader(fullname, candidate)
                return importlib.util.spec_from_file_location(fullname, candidate, loader=loader)
        return None


def stale_modules(root: str) -> list:
    """Listed modules whose ``.py`` under ``root`` (the folder holding ``bus/``) is newer than the
    compiled build: edited or checked out after the last install.

    The build's time is that of the group's shared library (``<GROUP>__mypyc``, rebuilt whenever
    any listed module changed); a module's own extension is a shim that an unchanged rebuild may
    leave with an old time, so it is not the reference.

    Returns
    -------
    list of str
        Dotted names; empty when nothing was compiled or the build is current.
    """
    built = None
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        try:
            built = os.stat(os.path.join(root, GROUP + "__mypyc" + suffix)).st_mtime
            break
        except OSError:
            continue
    if built is None:
        return []
    out = []
    for name in NATIVE_MODULES:
        try:
            if os.stat(os.path.join(root, *name.split(".")) + ".py").st_mtime > built:
                out.append(name)
        except OSError:
            continue
    return out


def install_source_finder() -> bool:
    """Run the Python source of the listed modules instead of their compiled extensions when
    ``SCHMIDT_FIL_NATIVE=0``, or when any listed ``.py`` is newer than its extension (a source
    edited, or a branch checked out, after the install compiled it: the compiled code would run
    the old version). All or none: compiled and source halves of the same classes must not mix.
    Idempotent; returns True if the source runs.
    """
    if any(f is _SourceFinder for f in sys.meta_path):
        return True
    if os.environ.get("SCHMIDT_FIL_NATIVE", "1") != "0":
        stale = stale_modules(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
        if not stale:
            return False
        print(f"schmidt-fil: {stale[0].replace('.', '/')}.py"
              f"{f' and {len(stale) - 1} more' if len(stale) > 1 else ''} changed after the hot path "
              f"was compiled; running the Python source (same results, slower). Reinstall "
              f"(pip install -e .) to compile it again.", file=sys.stderr)
    sys.meta_path.insert(0, _SourceFinder)
    return True
