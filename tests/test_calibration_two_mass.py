"""The backlash gap refitted with the load's inertia (issue 7, sessions 36–37; docs/calibration.md
"Session 36", "Session 37").

The load simulation of :mod:`plant.calibration.two_mass` is checked against the closed-form steady
state of a driven spring–damper–load (computed here with complex numbers, not with the module's
integrator); the estimate on the benchmark records where the massless description failed (fixed
independent seed 33, where session 36 found the load's inertia missing, and blind record 10760,
where session 37 found the load's friction level): regression tests, not the decision, which was
made on never-used seeds of both generators (`data/calibration_benchmark/session37_joint_friction/`).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from plant.calibration import two_mass
from plant.calibration.bench_records import make_record
from plant.calibration.fit import prepare
from plant.calibration.io import Record
from plant.calibration.loop import LoopConfig, run_loop
from plant.calibration.report import calibrate


@pytest.mark.parametrize("fs", [200.0, 1000.0, 2000.0])
@pytest.mark.parametrize("f_hz", [2.0, 9.0, 25.0])
def test_load_simulation_matches_the_driven_oscillators_steady_state(f_hz, fs):
    """No friction, no gap: ``J_l q̈_l = K (q − q_l) + c (q̇ − q̇_l)``, so the gear torque for
    ``q = A sin ωt`` is ``|G| A sin(ωt + ∠G)`` with ``G = J_l (iω)² (K + icω) / (K + icω − J_l ω²)``."""
    jl, k, c = 1.3, 4.0e4, 40.0       # load resonance 27.9 Hz, damping ratio 0.09
    t = np.arange(int(6.0 * fs)) / fs
    w = 2 * math.pi * f_hz
    a = 1e-3
    q = a * np.sin(w * t)
    n_sub = two_mass.substeps(1.0 / fs, k, 1.0, jl)
    tc = two_mass._load_sim(q, 1.0 / fs, n_sub, jl, k, c, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0)
    s = 1j * w
    g = jl * s**2 * (k + c * s) / (k + c * s + jl * s**2)
    tail = t > 3.0   # the start transient decays (time constant 2J_l/c = 65 ms)
    # the simulated response's complex amplitude at ω (least squares on sin, cos): the dynamics, not
    # the ripple of the piecewise-linear drive between samples
    basis = np.column_stack([np.sin(w * t[tail]), np.cos(w * t[tail])])
    (re, im), *_ = np.linalg.lstsq(basis, tc[tail], rcond=None)
    g_sim = (re + 1j * im) / a
    assert abs(g_sim - g) <= 0.025 * abs(g)   # measured worst 1.75 % (1 kHz, 25 Hz)


def test_stuck_load_carries_the_spring_up_to_the_static_level():
    """Coulomb friction on the load and a gap: the motor crosses the gap (no torque), then the spring
    winds up to ``Fc`` while the load sticks, then the load slides and the spring carries ``Fc``."""
    fs, k, gap, fc, jl = 1000.0, 1.0e4, 2e-4, 5.0, 2.0
    c = 2 * 0.3 * (k * jl) ** 0.5          # damping ratio 0.3: the slip's ringing dies out
    q = np.linspace(0.0, 3e-3, 3001)      # 3 mrad at 1 mrad/s: quasi-static
    wm = 1e-3
    tc = two_mass._load_sim(q, 1.0 / fs, 20, jl, k, c, 0.5 * gap, fc, fc, 0.0, 0.0, 0.0, 1.0, 0.0)
    d = q - q[0]
    inside = d < 0.5 * gap - 1e-6
    assert np.all(tc[inside] == 0.0)
    # the load sticks while the spring (and the damper, at the motor's speed) carries less than Fc
    winding = (d > 0.5 * gap + 1e-6) & (d < 0.5 * gap + (fc - c * wm) / k - 1e-6)
    assert winding.sum() > 300
    assert np.allclose(tc[winding], k * (d[winding] - 0.5 * gap) + c * wm, rtol=1e-6)
    assert np.allclose(tc[-500:], fc, rtol=0.02)


def test_refused_inputs_name_what_was_expected():
    t = np.arange(4000) / 200.0
    rec = Record(name="r", t_s=t, position=0.2 * np.sin(0.3 * t), torque=3.0 * np.sign(np.cos(0.3 * t)) + 0.1 * np.cos(0.3 * t))
    prep = prepare(rec)
    fit = run_loop(prep, None, LoopConfig()).final
    with pytest.raises(ValueError, match="gap must be positive"):
        two_mass.two_mass_gap(prep, fit, 1e4, 0.0)
    with pytest.raises(ValueError, match="positive stiffness"):
        two_mass.two_mass_gap(prep, fit, -1.0, 1e-4)


def test_seed_33_gap_with_the_load_inertia(tmp_path):
    """Fixed seed 33 (35.6 Hz drive, load 41 % of the inertia, 200 Hz): the massless gap is 54 % narrow;
    the two-mass gap predicts held-out blocks better and is within the issue's 30 %."""
    rec = make_record(33)
    rec.write_csv(tmp_path / "r.csv")
    rep = calibrate(tmp_path / "r.csv", tmp_path / "out", plots=False,
                    gear_stiffness=rec.meta["two_mass"]["stiffness_nm_rad"])
    (e,) = [e for e in rep["effects"] if e["kind"] == "backlash"]
    true = rec.truth["backlash"]["width_rad"]
    assert e["gap_method"] == two_mass.GAP_TWO_MASS
    assert e["two_mass"]["cv_gain_pct"] > 0
    assert abs(e["two_mass"]["massless_gap"] / true - 1) > 0.3
    assert abs(e["gap_rad"] / true - 1) <= 0.3
    text = (tmp_path / "out" / "report.md").read_text()
    assert "Two-mass refit" in text and "Used." in text


def test_blind_10760_load_friction_refitted_with_the_gap(tmp_path):
    """Blind-generator record 10760 (written without this module; a 6.8 Hz drive, 0.007 rad/s at most,
    the gap a tenth of the gear's wind-up): the massless fit trades Coulomb for viscous friction on so
    narrow a speed range (0.53 N·m for 0.72), which put session 36's two-mass gap 141 % wide. With the
    load's Coulomb and viscous levels refitted with the gap (session 37) the gap is within the issue's
    30 % and the load's Coulomb level is within 30 % of the generator's and nearer to it than the
    massless fit's. A regression test on the record the change was found on; the decision was made on
    never-used seeds (`data/calibration_benchmark/session37_joint_friction/`)."""
    from plant.calibration.blind_records import make_record as make_blind
    rec = make_blind(10760)
    rec.write_csv(tmp_path / "r.csv")
    rep = calibrate(tmp_path / "r.csv", tmp_path / "out", plots=False,
                    gear_stiffness=rec.meta["two_mass"]["stiffness_nm_rad"])
    (e,) = [e for e in rep["effects"] if e["kind"] == "backlash"]
    assert e["gap_method"] == two_mass.GAP_TWO_MASS
    assert abs(e["gap_rad"] / rec.meta["two_mass"]["backlash_width_rad"] - 1) <= 0.3
    true_fc = rec.meta["coulomb_nm"]
    fc_massless = e["two_mass"]["load_coulomb_massless"]
    fc_refit = fc_massless * e["two_mass"]["coulomb_scale"]
    assert abs(fc_refit / true_fc - 1) <= 0.3
    assert abs(fc_refit - true_fc) < abs(fc_massless - true_fc)
