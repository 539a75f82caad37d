"""Build hook: compile the emulator's hot path with mypyc (docs/performance.md, "Compiled hot path").

Everything else about the package is in pyproject.toml. The modules of :data:`NATIVE_MODULES`
(the scheduler, the CAN network model, ...) are the same Python source, type-checked and
compiled to C extension modules by mypyc (part of mypy), which a ``pip install`` builds; the
interpreter imports the extension instead of the ``.py`` beside it.

Decisions (and why):

* Compiled by default: it is the design that runs the telescope's network fastest; the source
  stays the reference and runs unchanged without a compiler.
* ``SCHMIDT_FIL_COMPILE=0`` at install time skips the compilation (pure Python).
* A failed compilation never fails the install: a machine without a C compiler, or a mypy that
  rejects the code, installs the pure-Python package with a warning (``schmidt-fil bench --json``
  reports which modules run compiled: ``native_modules``).
* At run time ``SCHMIDT_FIL_NATIVE=0`` imports the ``.py`` source instead of the compiled
  extensions (``bus/_native.py``), to compare or debug without reinstalling.
"""

import os
import runpy
import sys

from setuptools import setup

HERE = os.path.dirname(os.path.abspath(__file__))
#: Modules compiled by mypyc: one list, in bus/_native.py (standard library only, run here
#: before the package's dependencies exist).
_NATIVE = runpy.run_path(os.path.join(HERE, "bus", "_native.py"))
NATIVE_MODULES = [name.replace(".", "/") + ".py" for name in _NATIVE["NATIVE_MODULES"]]
#: name of the shared library mypyc builds for them (``<GROUP>__mypyc``, beside ``bus/``)
GROUP = _NATIVE["GROUP"]


def _native_extensions():
    if os.environ.get("SCHMIDT_FIL_COMPILE", "1") == "0":
        print("schmidt-fil: SCHMIDT_FIL_COMPILE=0, installing pure Python", file=sys.stderr)
        return []
    try:
        from mypyc.build import mypycify
        exts = mypycify(["--ignore-missing-imports", "--follow-imports=silent", *NATIVE_MODULES],
                        opt_level="3", group_name=GROUP)
    except (ImportError, SystemExit, Exception) as exc:   # noqa: BLE001 - any failure: pure Python
        print(f"schmidt-fil: WARNING: mypyc compilation not available ({exc!r}); installing "
              f"pure Python (slower, same results)", file=sys.stderr)
        return []
    for ext in exts:
        ext.optional = True           # a C compiler error leaves the pure-Python module in use
    return exts


setup(ext_modules=_native_extensions())
