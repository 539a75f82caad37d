"""Gear-train torque lines (plant/gear_train_disturbance.py, issue 9): orders, file schema, kernel."""

from __future__ import annotations

import math

import numpy as np
import pytest

from plant import kernel
from plant.axis import AxisPlant
from plant.gear_train_disturbance import LINE_ORDERS, line_frequency_hz, lines_table
from plant.params import ParameterError, load_parameters

MESH = "axes.ra.gear_disturbance.stage1_mesh"


def test_orders_follow_the_tooth_counts():
    """Orders are the issue's figures, and the motor order is the parameter file's gear ratio."""
    expect = {"axis_once": 1, "axis_twice": 2, "stage3_mesh": 250, "shaft2_once": 14.7, "stage2_mesh": 1809,
              "shaft1_once": 86.1, "motor_once": 360.5, "motor_twice": 721, "stage1_mesh": 9733, "roller_once": 24.5}
    for name, v in expect.items():
        assert LINE_ORDERS[name] == pytest.approx(v, rel=2e-3), name
    assert LINE_ORDERS["motor_once"] == pytest.approx(load_parameters().ra.gear.ratio, rel=1e-12)
    # the issue's frequencies: stage-1 mesh 4.5 Hz at 600"/s, 7.5 Hz at 1000"/s; 2x motor 0.056 Hz at 100"/s
    assert line_frequency_hz("stage1_mesh", 600) == pytest.approx(4.5, abs=0.05)
    assert line_frequency_hz("stage1_mesh", 1000) == pytest.approx(7.5, abs=0.05)
    assert line_frequency_hz("motor_twice", 100) == pytest.approx(0.056, abs=0.001)


def test_default_file_has_every_line_and_zero_except_identified():
    """Every line is in the file for both axes; only RA's stage-1 mesh may be non-zero."""
    p = load_parameters()
    for axis in ("ra", "dec"):
        gd = p.axes[axis].gear_disturbance
        assert set(gd) == set(LINE_ORDERS)
        for name, v in gd.items():
            if (axis, name) != ("ra", "stage1_mesh"):
                assert v["amplitude_nm"] == 0.0, (axis, name)
    src = p.tree["axes"]["ra"]["gear_disturbance"]["stage1_mesh"]["amplitude_nm"]["source"]
    assert "Fig. 6a" in src


@pytest.mark.parametrize("key,value,match", [
    ("axes.ra.gear_disturbance.stage1_mesh.amplitude_nm", -1.0, "must be >= 0"),
    ("axes.ra.gear_disturbance.stage1_mesh.amplitude_nm", "lots", "expected a number"),
])
def test_bad_values_name_the_path(key, value, match):
    with pytest.raises(ParameterError, match=match) as e:
        load_parameters(overrides={key: value})
    assert "axes.ra.gear_disturbance.stage1_mesh.amplitude_nm" in str(e.value)


def test_unknown_line_is_refused(tmp_path):
    import yaml

    from plant.params import DEFAULT_PATH

    tree = yaml.safe_load(DEFAULT_PATH.read_text())
    tree["axes"]["dec"]["gear_disturbance"]["stage4_mesh"] = tree["axes"]["dec"]["gear_disturbance"]["stage1_mesh"]
    f = tmp_path / "p.yaml"
    f.write_text(yaml.safe_dump(tree))
    with pytest.raises(ParameterError, match=r"axes\.dec\.gear_disturbance\.stage4_mesh: unknown gear line"):
        load_parameters(f)


def _schedule(ax, run, G=None):
    x = ax.state_tuple()
    out = []
    for duty_a, duty_b, ticks in [(0.30, 0.06, 150), (0.0, 0.0, 30), (0.05, 0.25, 150)]:
        for _ in range(ticks):
            o = run(x, ax._p, duty_a, duty_b, 5_000, ax.max_substep_us) if G is None else \
                run(x, ax._p, G, duty_a, duty_b, 5_000, ax.max_substep_us)
            x = o[0]
            out.append(o)
    return out


def test_zero_amplitudes_are_bit_identical():
    """An empty table and a table of zero-amplitude lines give the line-free kernel bit for bit."""
    ax = AxisPlant(load_parameters().ra)
    ref = _schedule(ax, kernel.twin_run)
    assert _schedule(ax, kernel.twin_run_lines, np.empty((0, 4))) == ref
    zero = np.array([[1.0, LINE_ORDERS["stage1_mesh"], 0.0, 0.7], [0.0, 1.0, 0.0, 1.3]])
    assert _schedule(ax, kernel.twin_run_lines, zero) == ref
    # and the plant object with every amplitude 0 runs the same numbers
    p0 = load_parameters(overrides={MESH + ".amplitude_nm": 0.0}).ra
    plant = AxisPlant(p0)
    assert plant._lines.shape == (0, 4)
    plant.set_duties(0.30, 0.06)
    for k in range(150):
        plant.advance_to((k + 1) * 5_000)
    assert plant.state_tuple() == ref[149][0]


@pytest.mark.parametrize("rigid", [False, True])
def test_lines_compiled_and_interpreted_agree(rigid):
    """With lines the compiled kernel agrees with the interpreted one, and the lines change the run."""
    if not kernel.JIT:
        pytest.skip("numba not installed or SCHMIDT_FIL_JIT=0")
    interp = kernel.interpreted()
    ov = {MESH + ".amplitude_nm": 30.0, "axes.ra.gear_disturbance.axis_once.amplitude_nm": 50.0,
          "axes.ra.gear_disturbance.axis_once.phase_rad": 0.4}
    if rigid:
        ov["axes.ra.drive_model"] = "rigid"
    ax = AxisPlant(load_parameters(overrides=ov).ra)
    G = ax._lines
    assert G.shape == (3, 4)
    run_c = kernel.rigid_run_lines if rigid else kernel.twin_run_lines
    run_i = interp.rigid_run_lines if rigid else interp.twin_run_lines
    oc, oi = _schedule(ax, run_c, G), _schedule(ax, run_i, G)
    for a, b in zip(oc, oi):
        for u, v in zip(a[0], b[0]):
            assert u == pytest.approx(v, rel=1e-9, abs=1e-15)
    plain = _schedule(ax, kernel.rigid_run if rigid else kernel.twin_run)
    assert max(abs(a[0][1] - b[0][1]) for a, b in zip(oc, plain)) > 1e-7


def test_lines_with_python_effects_path_match_kernel():
    """The Python substep loop (used with additive effects) adds the same line torque as the kernel."""
    ov = {MESH + ".amplitude_nm": 30.0}
    a = AxisPlant(load_parameters(overrides=ov).ra)
    b = AxisPlant(load_parameters(overrides=ov).ra, effects=[_ZeroEffect()])
    for pl in (a, b):
        pl.set_duties(0.3, 0.06)
        for k in range(200):
            pl.advance_to((k + 1) * 5_000)
    for u, v in zip(a.state_tuple(), b.state_tuple()):
        assert u == pytest.approx(v, rel=1e-9, abs=1e-12)


class _ZeroEffect:
    kind = "time_periodic"
    additive = True

    def torque_nm(self, theta, omega, t):
        return 0.0


def test_line_table_rows():
    """A train line gives two rows (trains A and B, own phases); an axis line one row."""
    G = lines_table({"stage1_mesh": {"amplitude_nm": 2.0, "phase_a_rad": 0.1, "phase_b_rad": 0.2},
                     "axis_twice": {"amplitude_nm": 3.0, "phase_rad": 0.3},
                     "motor_once": {"amplitude_nm": 0.0, "phase_a_rad": 0.0, "phase_b_rad": 0.0}})
    assert G.tolist() == [[1.0, LINE_ORDERS["stage1_mesh"], 2.0, 0.1], [2.0, LINE_ORDERS["stage1_mesh"], 2.0, 0.2],
                          [0.0, 2.0, 3.0, 0.3]]
    assert kernel.gear_lines_torque_nm(0.5, 0.6, 0.7, G) == pytest.approx(
        2.0 * math.sin(LINE_ORDERS["stage1_mesh"] * 0.6 + 0.1) + 2.0 * math.sin(LINE_ORDERS["stage1_mesh"] * 0.7 + 0.2)
        + 3.0 * math.sin(2.0 * 0.5 + 0.3))


def test_dump_round_trip_keeps_the_lines(tmp_path):
    """dump_parameters writes the gear lines back (values, units, sources) and they reload equal."""
    from plant.params import dump_parameters

    p = load_parameters(overrides={"axes.dec.gear_disturbance.motor_twice.phase_b_rad": 0.3})
    dump_parameters(p, tmp_path / "d.yaml")
    q = load_parameters(tmp_path / "d.yaml")
    assert q.axes["ra"].gear_disturbance == p.axes["ra"].gear_disturbance
    assert q.axes["dec"].gear_disturbance["motor_twice"]["phase_b_rad"] == 0.3
    assert q.tree["axes"]["ra"]["gear_disturbance"]["stage1_mesh"]["amplitude_nm"]["source"] == \
        p.tree["axes"]["ra"]["gear_disturbance"]["stage1_mesh"]["amplitude_nm"]["source"]
