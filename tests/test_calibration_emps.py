"""Calibration on the EMPS benchmark: the IDIM-LS reference, the loop, the report and the closed loop.

Tolerances (stated): M within 1 %, Fv within 2 %, Fc within 3 %, offset within 0.2 N, relative
error within 0.3 percentage points of the benchmark description (95.1089 kg, 203.5034 N·s/m,
20.3935 N, −3.1648 N, 4.08 %); closed-loop force error of the reference model within 0.3 pp of
the documented 5.85 %.
"""

import json
from pathlib import Path

import numpy as np
import pytest

from plant.calibration.fit import ModelSpec, fit_model, prepare
from plant.calibration.io import RecordError, load_csv, load_record, parse_columns

DATA = Path(__file__).resolve().parents[1] / "data" / "emps"
TRAIN = DATA / "DATA_EMPS.mat"
PULSES = DATA / "DATA_EMPS_PULSES.mat"


@pytest.fixture(scope="module")
def emps():
    return prepare(load_record(TRAIN))


def test_baseline_reproduces_benchmark_reference(emps):
    """The 4-parameter IDIM-LS fit reproduces the benchmark's reference identification."""
    f = fit_model(emps, ModelSpec())
    p = f.params()
    assert p["inertia"] == pytest.approx(95.1089, rel=0.01)
    assert p["viscous"] == pytest.approx(203.5034, rel=0.02)
    assert p["coulomb"] == pytest.approx(20.3935, rel=0.03)
    assert p["offset"] == pytest.approx(-3.1648, abs=0.2)
    assert f.relative_error_pct == pytest.approx(4.08, abs=0.3)
    assert np.all(f.std > 0) and np.all(f.std_eff >= f.std)


def test_reference_model_closed_loop_force_error():
    """The documented controller with the reference model gives the documented 5.85 % force error."""
    from plant.calibration.emps_closed_loop import force_error_pct, simulate_closed_loop

    rec = load_record(TRAIN)
    model = dict(mass=95.1089, fv_pos=203.5034, fv_neg=203.5034, fc_pos=20.3935, fc_neg=20.3935,
                 offset=-3.1648, stribeck=0.0, vs=1.0, additive=[])
    assert force_error_pct(rec, simulate_closed_loop(rec, model)) == pytest.approx(5.85, abs=0.3)


@pytest.fixture(scope="module")
def emps_report(tmp_path_factory):
    from plant.calibration.loop import LoopConfig
    from plant.calibration.report import calibrate

    out = tmp_path_factory.mktemp("emps")
    # the drive's documented lead, 2.5 mm per motor revolution (data/emps/README.md), declared as the
    # user would (--drive-periods 0.0025): the ripple moves the stage by ≈ 5 encoder quanta, which
    # the record alone cannot tell from the measurement chain's structure (docs/calibration.md,
    # "Session 19")
    calibrate(TRAIN, out, validate_path=PULSES, config=LoopConfig(drive_periods=(2.5e-3,)))
    return out, json.loads((out / "report.json").read_text())


def test_emps_loop_finds_documented_effects(emps_report):
    """The loop adds asymmetric friction first and the 2.5 mm motor-revolution ripple (declared as a
    drive period); held-out error falls."""
    out, rep = emps_report
    kinds = [e["kind"] for e in rep["effects"]]
    assert kinds[0] == "asymmetric_friction"
    af = rep["effects"][0]["params"]
    assert af["viscous_neg_n_s_m"] > af["viscous_pos_n_s_m"]  # PDF: 166.7 vs 240.4
    ripple = [e for e in rep["effects"] if e["kind"] == "position_periodic"]
    assert ripple and ripple[0]["params"]["period_m"] == pytest.approx(2.5e-3, rel=0.01)
    v = rep["validation"]
    # issue 7's target: the held-out rms of the calibrated model falls by >= 20 %. That model keeps the
    # torque-motion delay description (a property of the drive: docs/calibration.md); the plant file's
    # library effects alone must still lower it, by less.
    assert v["rms_after"] <= 0.80 * v["rms_before"]
    assert v["rms_after"] <= v["rms_after_library_only"] < 0.95 * v["rms_before"]
    delay = [u for u in rep["unexplained"] if u.get("kind") == "delay"]
    assert delay and "held-out prediction" in delay[0]["note"] and 0 < delay[0]["shift_s"] < 0.005
    assert rep["final"]["rms"] < rep["baseline"]["rms"]
    for key in ("baseline", "effects", "final", "validation", "unexplained", "model_file"):
        assert key in rep
    for e in rep["effects"]:
        assert set(e) >= {"kind", "params", "rms_after", "variance_explained_pct", "evidence"}
    for png in ("residual_vs_velocity.png", "residual_vs_position.png", "residual_spectra.png", "before_after.png"):
        assert (out / png).stat().st_size > 1000
    assert (out / "report.md").read_text().startswith("# Calibration report")
    assert rep["drive_periods"] == [2.5e-3] and "Declared periods of the drive" in (out / "report.md").read_text()


def test_emps_closed_loop_reported(emps_report):
    """The closed-loop force error is reported for the baseline (≈ 5.85 %) and with the effects."""
    _, rep = emps_report
    cl = rep["closed_loop"]
    assert cl["baseline_pct"] == pytest.approx(5.85, abs=0.3)
    assert cl["final_with_effects_pct"] < cl["baseline_pct"]


def test_calibrated_parameter_file_loads(emps_report):
    """The calibrated parameter file loads with the plant's loader and carries the effects."""
    from plant.params import load_parameters

    _, rep = emps_report
    params = load_parameters(rep["model_file"])
    kinds = [e["kind"] for e in params.axes["ra"].effects]
    assert kinds == [e["kind"] for e in rep["effects"]]
    assert params.axes["ra"].inertia_kg_m2 == pytest.approx(rep["final"]["params"]["mass_kg"])


def test_csv_errors_name_file_and_column(tmp_path):
    """CSV errors name the file, the column and what was expected; --columns maps names."""
    p = tmp_path / "rec.csv"
    t = np.arange(300) * 1e-3
    rows = "\n".join(f"{a},{b},{c}" for a, b, c in zip(t, np.sin(t), t))
    p.write_text("t,tau,pos\n" + rows + "\n")
    with pytest.raises(RecordError, match=r"rec\.csv.*'time_s'"):
        load_csv(p)
    rec = load_csv(p, columns=parse_columns("time_s=t,torque_nm=tau,position_rad=pos"), linear=True)
    assert rec.linear and len(rec) == 300
    bad = tmp_path / "bad.csv"
    bad.write_text("time_s,torque_nm,position_rad\n0,1,x\n" + rows + "\n")
    with pytest.raises(RecordError, match=r"bad\.csv.*'position_rad', row 2.*number"):
        load_csv(bad)
    with pytest.raises(ValueError, match="unknown canonical column"):
        parse_columns("speed=v")
