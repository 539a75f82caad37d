"""Instructions per simulated second of a network, counted by valgrind (a tool, not a test).

Wall-clock speed on the shared 2-core VM varies by up to 1.7× between minutes for the same build
(docs/performance.md, session 8), so a 5–10 % change cannot be seen in ``schmidt-fil bench``
without many interleaved runs. The number of instructions the CPU executes for the same
simulated span does not depend on the machine's load: callgrind counts them (≈ 0.1 % between
repeated runs). The count is a proxy for speed, not a replacement: a change that trades
instructions for cache misses would fool it, so a kept change is also checked with ``bench``.

Usage (needs ``valgrind``; ≈ 1–2 min)::

    python tests/tools/count_instructions.py [--network full] [--seconds 2]

The child process builds the network, runs a warm-up (1 s simulated, numba's kernels loaded),
builds it again, runs 0.2 s, then runs ``--seconds`` inside ``math.fsum`` (through a one-item
``map``); callgrind collects only inside that call (``--toggle-collect=math_fsum``). The marker
must be a function that nothing else in the process calls, before the span or in it: until
session 25 it was ``functools.reduce``, which numba's compiler calls (``reduce(operator.or_, …)``
in its dataflow analysis), so on the first run after an install, with numba's cache empty, the
kernels' compilation during the warm-up was counted too (107.6–109.4 M against 100.2 M on the
next run; docs/performance.md, "Session 25"). Prints instructions per simulated second, in
millions.
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

CHILD = r"""
import math, sys
sys.path.insert(0, {root!r})
from host.cli_bench import DEFAULT_SCENARIO, _with_boards, measure
from host.network import build_network
from host.scenario import load_scenario

net, sec = {network!r}, {seconds!r}
sc = load_scenario(DEFAULT_SCENARIO)
measure(sc, 1, "sim", net)                     # warm-up: imports, numba kernels, caches
sc = _with_boards(sc, net)
sc = sc.model_copy(update={{"bus": sc.bus.model_copy(update={{"interface": "sim", "channel": "count"}})}})
tel = build_network(sc)
assert tel.client.power_on().ok
seg = sc.segments[0]
tel.client.command_axis(seg.axis if seg.axis != "both" else "ra", seg.mode, seg.direction, seg.rate_arcsec_s)
tel.scheduler.run_until(tel.scheduler.now_us + 200_000)
t0 = tel.scheduler.now_us
math.fsum(map(lambda _: (tel.scheduler.run_until(t0 + int(sec * 1e6)), 0.0)[1], [0]))
tel.close()
from bus._native import native_modules
print("native", len(native_modules()))
"""


def count(network: str, seconds: float, keep: str | None = None) -> tuple[int, int]:
    """Instructions (callgrind ``Ir``) executed while ``seconds`` of ``network`` run, and how
    many of ``bus._native.NATIVE_MODULES`` ran compiled.

    Raises
    ------
    RuntimeError
        If valgrind is missing or its output has no instruction count.
    """
    if shutil.which("valgrind") is None:
        raise RuntimeError("valgrind not found (apt install valgrind)")
    with tempfile.TemporaryDirectory() as tmp:
        script = Path(tmp) / "child.py"
        script.write_text(CHILD.format(root=str(ROOT), network=network, seconds=seconds))
        out = subprocess.run(
            ["valgrind", "--tool=callgrind", f"--callgrind-out-file={tmp}/cg.out",
             "--toggle-collect=math_fsum", sys.executable, str(script)],
            capture_output=True, text=True, cwd=tmp)
        if keep:
            shutil.copyfile(f"{tmp}/cg.out", keep)
    m = re.search(r"Collected\s*:\s*(\d+)", out.stderr)
    n = re.search(r"^native (\d+)$", out.stdout, re.M)
    if out.returncode != 0 or m is None or n is None:
        raise RuntimeError(f"valgrind run failed (rc {out.returncode}): {out.stderr[-2000:]}")
    return int(m.group(1)), int(n.group(1))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--network", default="full")
    p.add_argument("--seconds", type=float, default=2.0)
    p.add_argument("--keep", metavar="FILE", help="copy callgrind's output here (read it with callgrind_annotate)")
    a = p.parse_args(argv)
    ir, native = count(a.network, a.seconds, a.keep)
    print(f"{a.network}: {ir / a.seconds / 1e6:.1f} M instructions per simulated second "
          f"({ir} over {a.seconds:g} s; {native} hot-path modules compiled)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
