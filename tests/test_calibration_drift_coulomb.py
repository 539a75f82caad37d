"""The Coulomb level of a model with the out-of-library friction drift in it (issue 7, session 31).

With ``friction_drift`` in the model the Coulomb torque is ``(Fc + c₁τ + c₂τ²)·sign``: the fit may
put ``Fc`` (the level at τ = 0) at its bound 0 while the drift columns carry the level. The rules
that need a Coulomb level (the declared gear spring's swing, the bristle behind it, σ0, the
backlash gap) must see the level over the record, not that coefficient — on independent seed 55 a
zero there skipped the gear-spring check and a compliant drive's wind-up was named backlash
(docs/calibration.md, "Session 31").

The record of the first test is made here by inverse dynamics of a prescribed motion (its own
code, its own quantisation and noise), not by the project's generators.
"""
from __future__ import annotations

import numpy as np
import pytest

from plant.calibration.fit import ModelSpec, fit_model, prepare
from plant.calibration.io import Record, load_record
from plant.calibration.loop import LoopConfig, friction_levels, run_loop


def _drifting_coulomb_record(seed: int, fc_start: float, fc_end: float) -> tuple[Record, float]:
    """Back-and-forth sweeps at several speeds; Coulomb level ramping linearly in time from
    ``fc_start`` to ``fc_end`` [N·m]. Returns the record and the Coulomb level's mean over it."""
    rng = np.random.default_rng(seed)
    fs, T = 500.0, 120.0
    t = np.arange(0.0, T, 1.0 / fs)
    # velocity: smoothed square-ish wave with a speed that changes every half period
    period = 12.0
    speeds = rng.uniform(0.02, 0.2, size=int(T / period * 2) + 2)
    half = np.floor(t / (period / 2)).astype(int)
    v_raw = speeds[half] * np.where(half % 2 == 0, 1.0, -1.0)
    k = int(0.4 * fs)                             # 0.4 s moving average: finite accelerations
    v = np.convolve(v_raw, np.ones(k) / k, mode="same")
    q = np.cumsum(v) / fs
    a = np.gradient(v, 1.0 / fs)
    J, fv = rng.uniform(5.0, 20.0), rng.uniform(20.0, 60.0)
    fc = fc_start + (fc_end - fc_start) * (t - t[0]) / (t[-1] - t[0])
    torque = J * a + fv * v + fc * np.tanh(v / 1e-4) + rng.normal(0.0, 0.05, t.size)
    quantum = 2 * np.pi / 2**24
    rec = Record(name=f"drift{seed}", t_s=t, position=np.round(q / quantum) * quantum, torque=torque)
    return rec, float(np.mean(fc))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_coulomb_level_with_a_drift_is_the_level_over_the_record(seed):
    rec, fc_mean = _drifting_coulomb_record(seed, fc_start=0.2, fc_end=2.0)
    prep = prepare(rec)
    fit = fit_model(prep, ModelSpec(nuisance=["friction_drift"]), refine=False)
    fc, ts = friction_levels(fit)
    assert fc == pytest.approx(fc_mean, rel=0.05)
    assert ts == fc                                          # no Stribeck term in this model
    # and the coefficient alone is the level at the start, far from the mean: the defect
    assert fit.param("coulomb") < 0.5 * fc_mean


def test_without_a_drift_the_level_is_the_coefficient():
    rec, fc_mean = _drifting_coulomb_record(3, fc_start=1.0, fc_end=1.0)
    fit = fit_model(prepare(rec), ModelSpec(), refine=False)
    assert friction_levels(fit)[0] == fit.param("coulomb")
    assert fit.param("coulomb") == pytest.approx(fc_mean, rel=0.05)


def test_compliant_drive_with_a_drift_is_not_named_backlash(tmp_path):
    """Independent seed 55 (a 3–12 Hz compliant mode, no gap; the benchmark declares its stiffness):
    the friction drift wins step 1 and, before session 31, backlash then passed at step 2 because
    the spring check read a Coulomb level of 0."""
    from plant.calibration.bench_records import make_record

    r = make_record(55)
    assert r.hidden == ("compliant_mode",)
    path = tmp_path / "r55.csv"
    r.write_csv(path)
    k = r.meta["two_mass"]["stiffness_nm_rad"]
    res = run_loop(prepare(load_record(path)), None, LoopConfig(gear_stiffness=k))
    assert "friction_drift" in [o["kind"] for o in res.out_of_library]
    named = {a.kind for a in res.accepted}
    assert not named & {"presliding", "backlash"}
    assert any(x["kind"] == "backlash" and x["step"] >= 2 and "declared gear spring" in x["reason"]
               for x in res.rejected)
