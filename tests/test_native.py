"""The compiled hot path (mypyc, ``bus/_native.py``; docs/performance.md "Compiled hot path").

The modules listed in ``bus._native.NATIVE_MODULES`` are compiled to C extensions at install; the
``.py`` source stays the reference. These tests check that (1) in CI every listed module really
runs compiled (a silently failed compilation would only show as a slower emulator), (2) the
compiled build and the source produce byte-identical logs and reports on scenarios that exercise
every board kind and every fault kind, and (3) ``SCHMIDT_FIL_NATIVE=0`` really runs the source.
The rest of the suite runs on whatever the install built (compiled in CI).
"""

from __future__ import annotations

import importlib
import os
import subprocess
import sys
from pathlib import Path

import pytest

from bus._native import NATIVE_MODULES, native_modules

ROOT = Path(__file__).resolve().parents[1]


def _compiled_build() -> bool:
    for name in NATIVE_MODULES:
        importlib.import_module(name)
    return bool(native_modules())


def test_every_listed_module_runs_compiled_where_the_install_compiled():
    """In CI (``CI`` set) the install must have compiled every listed module; elsewhere a
    pure-Python install is allowed (``SCHMIDT_FIL_COMPILE=0`` or no C compiler) and skips."""
    if not _compiled_build():
        if os.environ.get("CI"):
            pytest.fail("CI: no module of bus._native.NATIVE_MODULES runs compiled: the mypyc build "
                        "failed or was skipped at install (see the pip log)")
        pytest.skip("pure-Python install (SCHMIDT_FIL_COMPILE=0 at install, or no C compiler): "
                    "nothing compiled to compare")
    assert sorted(native_modules()) == sorted(NATIVE_MODULES)


def test_source_switch_imports_the_python_source():
    """``SCHMIDT_FIL_NATIVE=0`` imports every listed module from its ``.py`` file."""
    code = ("import importlib, bus._native as n\n"
            "mods = [importlib.import_module(m) for m in n.NATIVE_MODULES]\n"
            "assert all(m.__file__.endswith('.py') for m in mods), [m.__file__ for m in mods]\n"
            "print(len(n.native_modules()))\n")
    env = {**os.environ, "SCHMIDT_FIL_NATIVE": "0"}
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True,
                         text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "0"


def test_compiled_and_source_write_identical_logs(tmp_path):
    """Byte-identical outputs (wall-clock fields aside) on the full network (17 boards) and on
    the two fault scenarios of tests/tools/same_logs.py (every CAN fault kind, resets, malformed
    frames, reader loss, board removal, RS232 telemetry)."""
    if not _compiled_build():
        pytest.skip("pure-Python install: source against source would compare nothing")
    tool = ROOT / "tests" / "tools" / "same_logs.py"
    only = ["--only", "full-slew-track", "faults-can", "faults-boards"]
    src = subprocess.run([sys.executable, str(tool), "--out", str(tmp_path / "source"), *only],
                         cwd=ROOT, env={**os.environ, "SCHMIDT_FIL_NATIVE": "0", "MPLBACKEND": "Agg"},
                         capture_output=True, text=True, timeout=900)
    assert src.returncode == 0, src.stdout[-2000:] + src.stderr[-2000:]
    nat = subprocess.run([sys.executable, str(tool), "--out", str(tmp_path / "compiled"),
                          "--against", str(tmp_path / "source"), *only],
                         cwd=ROOT, env={**os.environ, "MPLBACKEND": "Agg"},
                         capture_output=True, text=True, timeout=900)
    assert nat.returncode == 0, nat.stdout[-3000:] + nat.stderr[-2000:]
    assert "identical" in nat.stdout
    runs = sorted(p.name for p in (tmp_path / "compiled").iterdir())
    assert runs == ["faults-boards", "faults-can", "full-slew-track"]


def test_compiled_bus_classes_keep_their_own_abc_caches():
    """python-can ``BusABC`` subclasses compiled by mypyc get their own ABC caches
    (``bus._native.own_abc_cache``): asking about the base first must not make one bus class
    an instance of the other."""
    import can

    from bus.simbus import SimBus
    from host.gateway_bus import HidGatewayBus

    assert issubclass(SimBus, can.BusABC) and issubclass(HidGatewayBus, can.BusABC)
    assert not issubclass(SimBus, HidGatewayBus) and not issubclass(HidGatewayBus, SimBus)
    for cls in (SimBus, HidGatewayBus):
        assert "_abc_impl" in cls.__dict__


def test_a_source_newer_than_the_build_is_detected(tmp_path):
    """``stale_modules``: a listed ``.py`` newer than the group's shared library (edited or
    checked out after the install) is named, so ``bus`` runs the source instead of old compiled
    code; nothing is stale without a build, or when the build is newer."""
    import importlib.machinery

    from bus._native import GROUP, stale_modules

    suffix = importlib.machinery.EXTENSION_SUFFIXES[0]
    src = tmp_path / "bus" / "network.py"
    src.parent.mkdir()
    src.write_text("# source\n")
    assert stale_modules(str(tmp_path)) == []                 # nothing compiled
    lib = tmp_path / f"{GROUP}__mypyc{suffix}"
    lib.write_bytes(b"\0")
    os.utime(src, (1_000, 1_000))
    os.utime(lib, (2_000, 2_000))
    assert stale_modules(str(tmp_path)) == []                 # built after the edit
    os.utime(src, (3_000, 3_000))
    assert stale_modules(str(tmp_path)) == ["bus.network"]    # edited after the build
