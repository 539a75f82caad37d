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
import sysconfig

from setuptools import setup
from setuptools.command.build_ext import build_ext

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
    except (SystemExit, Exception) as exc:   # noqa: BLE001 - any failure: pure Python
        print(f"schmidt-fil: WARNING: mypyc compilation not available ({exc!r}); installing "
              f"pure Python (slower, same results)", file=sys.stderr)
        return []
    for ext in exts:
        ext.optional = True           # a C compiler error leaves the pure-Python module in use
    return exts


class BuildNative(build_ext):
    """``build_ext``, all or none: the compiled files of an earlier install are removed first,
    and if any extension fails (they are optional: the install goes on), every compiled file
    is removed again, so Python imports the source of every listed module. Without this, a
    failed rebuild of the shared library would leave the previous one in place behind new
    shims, running old code."""

    def _outputs(self) -> list:
        paths = set()
        for ext in self.extensions:
            paths.add(self.get_ext_fullpath(ext.name))
            rel = os.path.join(*ext.name.split(".")) + sysconfig.get_config_var("EXT_SUFFIX")
            paths.add(os.path.join(HERE, rel))            # in the source tree (editable install)
        return sorted(paths)

    def _remove_outputs(self) -> None:
        for path in self._outputs():
            if os.path.exists(path):
                os.remove(path)

    def run(self) -> None:
        self._failed = []
        self._remove_outputs()
        super().run()
        if self._failed:
            self._remove_outputs()
            print(f"schmidt-fil: WARNING: compiling {', '.join(self._failed)} failed; no module is "
                  f"compiled: installing pure Python (slower, same results)", file=sys.stderr)

    def build_extension(self, ext) -> None:
        try:
            super().build_extension(ext)
        except Exception:
            self._failed.append(ext.name)
            raise


setup(ext_modules=_native_extensions(), cmdclass={"build_ext": BuildNative})
