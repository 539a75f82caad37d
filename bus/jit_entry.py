"""The compiled entry point of a numba kernel, called without numba's per-call type dispatch.

Calling a numba ``njit`` function from Python goes through its dispatcher, which types every
argument (``typeof``) to choose the compiled version on *every* call: for
:func:`plant.kernel.twin_run` (a tuple of 11 floats, a tuple of 22 floats and four scalars) that
is ≈ 0.8 µs of a ≈ 1.8 µs call, and for :func:`bus.bitkernel.frame_bits_kernel` ≈ 0.23 µs of
0.59 µs (measured on this VM, session 9). The emulator calls these kernels with the same argument
types every time (the plant ≈ 800 times, the frame length ≈ 3500 times per simulated second of the
``full`` network), so the choice can be made once: a numba ``CompileResult`` keeps the Python
callable of the compiled version (``entry_point``), which unboxes its arguments as its signature
says and runs.

That callable converts instead of checking: a Python ``int`` passed where the signature has
``float64`` becomes a float (right), but a ``float`` passed for an ``int64`` would be truncated.
So the version is chosen for *canonical* example arguments (the types the kernel is meant for),
given by the caller, never from whatever the first call happened to pass.

``dispatcher.overloads`` and ``CompileResult.entry_point`` are numba internals (stable since numba
0.4x; what ``Dispatcher.__call__`` itself ends up calling). If they are missing, or numba is not
in use (``SCHMIDT_FIL_JIT=0``), the function is returned as it is: slower, same results.
"""

from __future__ import annotations

from typing import Any, Callable

__all__ = ["entry_point"]


def entry_point(fn: Callable[..., Any], example_args: tuple) -> Callable[..., Any]:
    """The compiled version of ``fn`` for the types of ``example_args``, as a plain callable.

    Parameters
    ----------
    fn : callable
        A numba dispatcher (``njit`` function), or a plain Python function.
    example_args : tuple
        Arguments of the canonical types (e.g. floats where the kernel computes in float64). The
        kernel is called once with them to compile it or load it from numba's disk cache; it
        must therefore be free of side effects (every kernel of this project is).

    Returns
    -------
    callable
        ``CompileResult.entry_point`` for that signature; ``fn`` itself when ``fn`` is not a numba
        dispatcher or its internals are not as expected.
    """
    overloads = getattr(fn, "overloads", None)
    typeof = getattr(fn, "typeof_pyval", None)
    if overloads is None or typeof is None:
        return fn
    fn(*example_args)
    cres = overloads.get(tuple(typeof(a) for a in example_args))
    ep = getattr(cres, "entry_point", None)
    return ep if callable(ep) else fn
