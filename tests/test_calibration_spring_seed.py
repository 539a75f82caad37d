"""The declared gear spring's Coulomb level where the rigid fit's is 0 (issue 7, session 50).

With the drive's stiffness declared, a pre-sliding or backlash candidate must predict held-out
blocks better than the current model with that spring in it (session 20, ``loop._beats_gear_spring``):
after each reversal the load sticks until the spring carries ``Fc``, so the motor sees a friction
that swings over ``2Fc/K``. ``Fc`` was the current fit's Coulomb level. On a soft drive the rigid
fit can hold that level at its bound 0 (the motor sees the friction as the spring's wind-up, a ramp
the step column cannot take); the spring then had no swing and the candidate no test at all. Blind
records 20390 and 20442 (compliant modes, no gap) were named backlash that way. The spring's fixed
point now starts from the candidate's own Coulomb level there.

Two kinds of record: a soft two-mass drive written in this file (its own integrator, a PI velocity
loop on the motor encoder's differenced counts, the motor torque logged with noise), on which the
rigid fit's Coulomb level is 0; and blind 20390, written by the blind generator (session 24), on
which the hole named a backlash (the decision was made on never-used seeds,
``data/calibration_benchmark/session50_spring_seed/``).
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from plant.calibration import loop
from plant.calibration.blind_records import make_record as make_blind
from plant.calibration.fit import fit_model, prepare
from plant.calibration.io import Record
from plant.calibration.report import calibrate


def _soft_drive_record(seed: int, f_hz: tuple[float, float] = (1.5, 3.0), gap_rel: float = 0.0,
                       fs: float = 500.0, duration: float = 80.0) -> tuple[Record, float]:
    """Motor ``Jm`` — spring ``K`` and damper (ζ 0.03, acting in contact) — load ``Jl`` with friction
    ``Fc·tanh(vl/1e-4) + Fv·vl``; its first mode drawn in ``f_hz`` [Hz]; a gap in the spring of
    ``gap_rel`` × 0.3–1 × the wind-up ``2Fc/K`` (0: none). A PI velocity loop (8 Hz bandwidth) on the
    motor encoder's differenced counts (22 bits) follows four legs of alternating ±0.02–0.05 rad/s with
    1 s ramps; the motor torque is logged with 0.02 N·m noise. Semi-implicit Euler, 20 sub-steps per
    sample (the same records as ``data/calibration_benchmark/session50_spring_seed/soft_drive_probe.py``).
    Returns the record and ``K`` [N·m/rad]."""
    rng = np.random.default_rng(seed)
    jm, jl = rng.uniform(0.4, 0.8), rng.uniform(0.4, 0.8)
    jr = jm * jl / (jm + jl)
    stiffness = (2 * np.pi * rng.uniform(*f_hz)) ** 2 * jr
    damping = 2 * 0.03 * np.sqrt(stiffness * jr)
    fc, fv, vmax = rng.uniform(0.3, 1.0), rng.uniform(5.0, 20.0), rng.uniform(0.02, 0.05)
    half_gap = 0.5 * gap_rel * rng.uniform(0.3, 1.0) * 2 * fc / stiffness
    n, dt, sub = int(duration * fs), 1.0 / fs, 20
    h = dt / sub
    t = np.arange(n) * dt
    leg = np.minimum((t / (duration / 4)).astype(int), 3)
    k = int(fs)
    v_ref = np.convolve(np.pad(vmax * np.where(leg % 2 == 0, 1.0, -1.0), (k, k), mode="edge"), np.ones(k) / k,
                        mode="same")[k:-k]
    v_ref[: int(0.5 * fs)] = 0.0
    v_ref[-int(0.5 * fs):] = 0.0
    quantum = 2 * np.pi / 2**22
    kp, ki = 8.0 * (jm + jl) * 2 * np.pi, 8.0 * (jm + jl) * (2 * np.pi) ** 2
    qm = ql = vm = vl = integ = q_prev = 0.0
    pos, tau_log = np.empty(n), np.empty(n)
    for i in range(n):
        qc = round(qm / quantum) * quantum
        err = v_ref[i] - (qc - q_prev) / dt
        q_prev = qc
        integ += ki * err * dt
        tau = kp * err + integ
        pos[i], tau_log[i] = qc, tau
        for _ in range(sub):
            d = qm - ql
            wind = d - half_gap if d > half_gap else (d + half_gap if d < -half_gap else 0.0)
            f_spring = stiffness * wind + (damping * (vm - vl) if wind != 0.0 else 0.0)
            vm += h * (tau - f_spring) / jm
            vl += h * (f_spring - fc * np.tanh(vl / 1e-4) - fv * vl) / jl
            qm += h * vm
            ql += h * vl
    return Record(name=f"soft{seed}", t_s=t, position=pos, torque=tau_log + rng.normal(0.0, 0.02, n)), stiffness


def _named(rec: Record, stiffness: float) -> list[str]:
    cfg = dataclasses.replace(loop.LoopConfig(), gear_stiffness=stiffness)
    return [a.kind for a in loop.run_loop(prepare(rec), None, cfg).accepted]


def test_the_spring_is_built_from_a_seed_where_the_rigid_coulomb_is_zero():
    """On the file's soft drive the rigid baseline's Coulomb level is 0: without a seed no spring (the
    hole), with a candidate's level as the seed a positive fixed point."""
    rec, stiffness = _soft_drive_record(0)
    prep = prepare(rec)
    cfg = dataclasses.replace(loop.LoopConfig(), gear_stiffness=stiffness)
    base, _ = loop.fit_baseline(prep, cfg)
    assert loop._coulomb(base) == 0.0
    assert loop._spring_coulomb(prep, base, cfg) is None
    fc = loop._spring_coulomb(prep, base, cfg, seed=1.0)
    assert fc is not None and fc > 0
    # the fixed point does not depend much on where it starts (two refits from 0.5 and 2 N·m)
    fc_lo, fc_hi = loop._spring_coulomb(prep, base, cfg, seed=0.5), loop._spring_coulomb(prep, base, cfg, seed=2.0)
    assert fc_lo is not None and fc_hi is not None
    assert abs(fc_hi - fc_lo) < 0.5 * (fc_hi + fc_lo) / 2
    # without a declared stiffness there is no spring, seed or not
    assert loop._spring_coulomb(prep, base, dataclasses.replace(cfg, gear_stiffness=None), seed=1.0) is None


def test_blind_20390_compliant_mode_is_not_named_backlash(monkeypatch, tmp_path):
    """Blind 20390 (a compliant mode, no gap): the backlash candidate now meets the declared spring,
    started from its own Coulomb level, and loses to it; nothing is named. With the seed ignored
    (main before session 50) backlash is named, so the check can fail."""
    rec = make_blind(20390)
    assert rec.hidden == ("compliant_mode",)
    stiffness = rec.meta["two_mass"]["stiffness_nm_rad"]
    rec.write_csv(tmp_path / "r.csv")
    rep = calibrate(tmp_path / "r.csv", tmp_path / "out", plots=False, gear_stiffness=stiffness)
    assert [e["kind"] for e in rep["effects"]] == []
    (why,) = [r["reason"] for r in rep["rejected"] if r["kind"] == "backlash"]
    assert "started from the candidate's" in why and "predicts held-out blocks as well" in why
    real = loop._spring_coulomb
    monkeypatch.setattr(loop, "_spring_coulomb", lambda prep, cur, cfg, seed=None, **kw: real(prep, cur, cfg, **kw))
    rep2 = calibrate(tmp_path / "r.csv", tmp_path / "out2", plots=False, gear_stiffness=stiffness)
    assert [e["kind"] for e in rep2["effects"]] == ["backlash"]


def test_the_spring_coulomb_is_its_fixed_point_not_two_refits(monkeypatch):
    """Probe seed 0 with its mode at 3–6 Hz (no gap): the rigid fit's Coulomb level is small but
    positive, and two refits left the spring's far below its fixed point (0.34 against 0.46 N·m, reached
    from 0.05 and from 3 N·m alike); with that spring a pre-sliding was named on a drive without one.
    Refitted to convergence nothing is named; with the old two refits patched back it is, so the check
    can fail."""
    rec, stiffness = _soft_drive_record(0, f_hz=(3.0, 6.0))
    prep = prepare(rec)
    cfg = dataclasses.replace(loop.LoopConfig(), gear_stiffness=stiffness)
    base, _ = loop.fit_baseline(prep, cfg)
    assert 0 < loop._coulomb(base) < 0.1
    fc = loop._spring_coulomb(prep, base, cfg)
    assert fc is not None
    # the test's own iteration from far above lands on the same level
    level = 3.0
    for _ in range(60):
        spec = dataclasses.replace(base.spec.copy(), gear_stiffness=stiffness, spring_coulomb=level)
        level = loop._coulomb(fit_model(prep, spec, refine=False))
    assert abs(level - fc) < 0.01 * fc
    assert _named(rec, stiffness) == []
    monkeypatch.setattr(loop, "SPRING_COULOMB_MAX_REFITS", 2)
    assert abs(loop._spring_coulomb(prep, base, cfg) - fc) > 0.1 * fc
    assert _named(rec, stiffness) in (["presliding"], ["backlash"])


@pytest.mark.parametrize("seed", [0, 1])
def test_a_gap_in_a_soft_drive_is_still_named_backlash(seed):
    """The same probe drives with a gap of 0.3–1 × a wind-up in their spring (mode 3–6 Hz): backlash is
    named, as before the change (probe seeds 0, 1, 3, 6, 8, 9 of 0–9 in both trees)."""
    rec, stiffness = _soft_drive_record(seed, f_hz=(3.0, 6.0), gap_rel=1.0)
    assert _named(rec, stiffness) == ["backlash"]
