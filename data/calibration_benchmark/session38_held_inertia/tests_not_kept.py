"""A candidate that drives the inertia to 0 is tested with the inertia held (issue 7, session 38).

Session 14's rule refused such a candidate outright, as a smooth stand-in for the noisy measured
acceleration. It also refused real torques whose columns share part of the acceleration's
direction: blind-generator record 10016 (a 2.65 N·m position line on a staircase) had its line in
``unexplained``. Since session 38 the candidate is fitted and cross-validated with the inertia held at
the current model's value: a stand-in has nothing left to explain, a torque of its own keeps its
gain (docs/calibration.md, "Session 38"). The held fit is checked here against least squares and
blocked cross-validation written in this file with numpy alone; the loop on records of both
generators (written without the loop's effect code). Regression tests on the records the change was
found and guarded on; the decision was made on never-used seeds
(``data/calibration_benchmark/session38_held_inertia/``).
"""
from __future__ import annotations

import numpy as np
import pytest

from plant.calibration import fit, loop
from plant.calibration.bench_records import make_record
from plant.calibration.blind_records import make_record as make_blind
from plant.calibration.io import load_record
from plant.calibration.report import calibrate


@pytest.fixture(scope="module")
def prep_3048(tmp_path_factory):
    path = tmp_path_factory.mktemp("r") / "rec.csv"
    make_record(3048).write_csv(path)
    return fit.prepare(load_record(path))


def test_held_fit_is_least_squares_on_the_rest(prep_3048):
    spec = fit.ModelSpec()
    names, X = fit.design(prep_3048, spec)
    i = names.index("inertia")
    j_held = 0.5 * fit.fit_model(prep_3048, spec).param("inertia")
    f = fit.fit_model(prep_3048, spec, fixed={"inertia": j_held})
    y = prep_3048.y_dec - j_held * X[:, i]
    rest = [k for k in range(len(names)) if k != i]
    coef, *_ = np.linalg.lstsq(X[:, rest], y, rcond=None)
    assert f.param("inertia") == j_held and f.std[i] == 0.0
    assert all(c >= 0 for n, c in zip([names[k] for k in rest], coef) if n in fit.NONNEGATIVE)  # lstsq is the answer
    np.testing.assert_allclose(f.coef[rest], coef, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(f.residual, y - X[:, rest] @ coef, atol=1e-9)
    assert f.n_params == len(names) - 1


def test_held_parameter_not_in_the_design_is_named(prep_3048):
    with pytest.raises(KeyError, match="grav_sin"):
        fit.fit_model(prep_3048, fit.ModelSpec(), fixed={"grav_sin": 1.0})


def test_held_cross_validation_is_blocked_least_squares_on_the_rest(prep_3048):
    spec = fit.ModelSpec()
    names, X = fit.design(prep_3048, spec)
    i = names.index("inertia")
    j_held = 1.7
    err = loop.cv_losses(prep_3048, spec, k_folds=8, fixed={"inertia": j_held})
    y = prep_3048.y_dec
    rest = [k for k in range(len(names)) if k != i]
    edges = np.linspace(0, y.size, 9).astype(int)
    want = np.empty(y.size)
    for a, b in zip(edges[:-1], edges[1:]):
        tr = np.r_[0:a, b:y.size]
        c, *_ = np.linalg.lstsq(X[tr][:, rest], y[tr] - j_held * X[tr, i], rcond=None)
        want[a:b] = y[a:b] - j_held * X[a:b, i] - X[a:b][:, rest] @ c
    np.testing.assert_allclose(np.asarray(err), want, atol=1e-8)


def _named(path):
    return [e.kind for e in loop.run_loop(fit.prepare(load_record(path))).effects()]


def test_a_stand_in_held_at_the_inertia_has_nothing_left(monkeypatch, tmp_path):
    """Independent seed 3048 (friction drift, a sinusoid): a time line stands in for ``J·θ̈``. With the
    phase guard patched out, the held test alone must refuse it; with the held test also patched out
    (the candidate's free fit used as is) the line is named, so the check can fail."""
    path = tmp_path / "rec.csv"
    make_record(3048).write_csv(path)
    monkeypatch.setattr(loop, "periodic_motion_hz", lambda prep: (None, 0.0))
    assert "time_periodic" not in _named(path)
    monkeypatch.setattr(loop, "_replaces_inertia", lambda cur, new: None)
    assert "time_periodic" in _named(path)


def _line(rep):
    return [e for e in rep["effects"] if e["kind"] == "position_periodic"]


def test_blind_10016_position_line_found_with_the_inertia_held(monkeypatch, tmp_path):
    """Blind record 10016: the line (period 0.0162 rad, 2.65 N·m) is named within the issue's 3 % and
    30 %, with the held inertia in its evidence; with the held test patched out (session 14's outright
    refusal) it is not named."""
    rec = make_blind(10016)
    rec.write_csv(tmp_path / "r.csv")
    truth = rec.truth["position_periodic"]
    rep = calibrate(tmp_path / "r.csv", tmp_path / "out", plots=False)
    (e,) = _line(rep)
    assert abs(e["params"]["period_rad"] / truth["period_rad"] - 1) <= 0.03
    assert abs(e["params"]["amplitude_nm"] / truth["amplitude_nm"] - 1) <= 0.3
    assert "inertia held at" in e["evidence"]
    monkeypatch.setattr(loop, "_hold_inertia", lambda *a, **k: None)
    assert _line(calibrate(tmp_path / "r.csv", tmp_path / "out2", plots=False)) == []
