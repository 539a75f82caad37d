"""The plant kernel gives the same numbers compiled (numba) and interpreted (plain Python)."""

from __future__ import annotations

import pytest

from plant import kernel
from plant.axis import AxisPlant
from plant.params import load_parameters


@pytest.fixture(scope="module")
def interpreted():
    """A second copy of plant.kernel loaded with SCHMIDT_FIL_JIT=0 (every function interpreted)."""
    mod = kernel.interpreted()
    assert mod.BACKEND == "python" and mod.twin_run is not kernel.twin_run
    return mod


CASES = [
    # (overrides, duty schedule [(duty_a, duty_b, ticks)])
    ({"axes.ra.friction.preload": "low"}, [(0.30, 0.075, 200), (0.0, 0.0, 50), (0.05, 0.2, 200)]),
    ({"axes.ra.friction.preload": "high"}, [(0.9, 0.2, 100), (0.2, 0.9, 100)]),   # breakaway, then reversal
    ({"axes.ra.drive_model": "rigid"}, [(0.3, 0.075, 200), (0.0, 0.6, 100)]),
    ({"perfect": True}, [(0.3, 0.0, 100), (0.0, 0.0, 100)]),
]


@pytest.mark.parametrize("overrides,schedule", CASES)
def test_compiled_and_interpreted_agree(interpreted, overrides, schedule):
    if not kernel.JIT:
        pytest.skip("numba not installed or SCHMIDT_FIL_JIT=0: only the interpreted kernel exists")
    ax = AxisPlant(load_parameters(overrides=overrides).ra)
    run_c = kernel.rigid_run if ax.rigid else kernel.twin_run
    run_i = interpreted.rigid_run if ax.rigid else interpreted.twin_run
    xc = xi = ax.state_tuple()
    moved = 0.0
    for duty_a, duty_b, ticks in schedule:
        for _ in range(ticks):
            oc = run_c(xc, ax._p, duty_a, duty_b, 5_000, ax.max_substep_us)
            oi = run_i(xi, ax._p, duty_a, duty_b, 5_000, ax.max_substep_us)
            xc, xi = oc[0], oi[0]
            assert oc[6:] == oi[6:]                       # µs over the current rating: integers
            for a, b in zip(oc[1:6], oi[1:6]):
                assert a == pytest.approx(b, rel=1e-9, abs=1e-12)
        for a, b in zip(xc, xi):
            assert a == pytest.approx(b, rel=1e-9, abs=1e-15)
        moved = max(moved, abs(xc[1]))
    assert moved > 1e-5  # the schedules really move the axis (> 2″/s)


def test_substeps_split_spans_exactly():
    """One 5 ms span equals ten 500 µs spans (same substeps), and a 730 µs span = 500 + 230."""
    ax = AxisPlant(load_parameters().ra)
    x0 = ax.state_tuple()
    one = kernel.twin_run(x0, ax._p, 0.4, 0.1, 5_000, 500)[0]
    x = x0
    for _ in range(10):
        x = kernel.twin_run(x, ax._p, 0.4, 0.1, 500, 500)[0]
    assert x == one
    a = kernel.twin_run(x0, ax._p, 0.4, 0.1, 730, 500)[0]
    b = kernel.twin_run(kernel.twin_run(x0, ax._p, 0.4, 0.1, 500, 500)[0], ax._p, 0.4, 0.1, 230, 500)[0]
    assert a == b


def test_entry_point_is_the_compiled_kernel_and_converts_ints_to_floats():
    """bus.jit_entry.entry_point: the compiled version itself (no dispatcher), same results as the
    dispatcher; an ``int`` where the kernel computes in float64 is converted, not mis-read; a plain
    Python function comes back unchanged."""
    from bus.bitkernel import frame_bits_kernel
    from bus.jit_entry import entry_point

    ax = AxisPlant(load_parameters().ra)
    state = tuple(float(v) for v in ax.state_tuple())
    fast = entry_point(kernel.twin_run, (state, ax._p, 0.0, 0.0, 1, ax.max_substep_us))
    if not kernel.JIT:
        assert fast is kernel.twin_run
        pytest.skip("numba not installed or SCHMIDT_FIL_JIT=0: nothing to resolve")
    assert fast is not kernel.twin_run and not hasattr(fast, "overloads")
    x = state
    for duty_a, duty_b in [(0.3, 0.075), (0.3, 0.075), (0, 1), (0.05, 0.2)]:   # ints included
        a = fast(x, ax._p, duty_a, duty_b, 5_000, ax.max_substep_us)
        b = kernel.twin_run(x, ax._p, float(duty_a), float(duty_b), 5_000, ax.max_substep_us)
        assert a == b
        x = a[0]
    assert x != state                               # it moved: the comparison was not of rest states
    bits = entry_point(frame_bits_kernel, (0x7FF, 8, 0, 0))
    assert bits is not frame_bits_kernel
    for args in [(0x181, 8, 0x12345678, 0x9ABCDEF0), (0x000, 0, 0, 0), (0x7FF, 2, 0, 0xFFFF)]:
        assert bits(*args) == frame_bits_kernel(*args)

    def plain(v):
        return v + 1
    assert entry_point(plain, (1,)) is plain
