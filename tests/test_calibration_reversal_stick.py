"""A pre-sliding is refused where the record's axis sticks at its reversals (session 45:
``plant.calibration.residuals.reversal_dwell_swings``, ``plant.calibration.loop._sticks_at_reversals``).

The physics under test: a LuGre bristle makes the friction's reversal step a function of the
displacement, so at the turning point (within a couple of encoder counts) a bristle of ``n`` counts
changes the friction by at most ``2(1 − exp(−2.5/n))·Fc``. With stiff bristles the axis sticks
instead: the servo ramps its torque through the static band (``Fc + Fs``) while the position stays.

The records of the first tests come from the equations, with their own integrator, not from
``plant/`` or either benchmark generator: a rigid axis with LuGre friction (Stribeck curve,
bristle state advanced implicitly) in a sampled PI velocity loop with a position loop, moved back
and forth at constant rate with limited-acceleration turns, logged through a quantising encoder
with the torque command plus noise. The last test uses the blind generator's record 14278
(``plant.calibration.blind_records``, written without reading the loop), where the rule was found.
"""
import math

import numpy as np
import pytest

from plant.calibration.fit import ModelSpec, fit_model, prepare
from plant.calibration.io import Record
from plant.calibration.residuals import DWELL_QUANTA, reversal_dwell_swings

J, FC, FS, FV, VS = 2.0, 1.0, 1.3, 40.0, 2e-3     # kg·m², N·m, N·m, N·m·s/rad, rad/s
QUANTUM = 2 * math.pi / 2**23                       # rad, a 23-bit encoder


def _lugre_sweep(bristle_quanta: float, seed: int = 0, legs: int = 8) -> Record:
    """Back-and-forth sweep (0.05 rad/s over 0.6 rad, turns at 0.1 rad/s²) of a LuGre axis whose
    bristle deflects ``Fc/σ0 = bristle_quanta`` encoder counts under the Coulomb load.

    10 kHz integration, 2 kHz control (PI velocity loop at 40 rad/s on differenced counts, position
    loop at a quarter of that), 500 Hz log of the quantised position and the torque command plus
    0.01 N·m noise.
    """
    rng = np.random.default_rng(seed)
    sigma0 = FC / (bristle_quanta * QUANTUM)
    sigma1 = math.sqrt(sigma0 * J)                  # damping ratio 0.5 of the bristle mode
    rate, acc, travel = 0.05, 0.1, 0.6
    h, ctrl_every, log_every = 1e-4, 5, 20
    t_leg = travel / rate + rate / acc
    n = int(legs * t_leg / h)
    t = np.arange(n) * h
    leg = (t // t_leg).astype(int)
    tl = t - leg * t_leg
    v_ref = (np.where(leg % 2 == 0, 1.0, -1.0) * np.minimum(rate, np.minimum(acc * tl, acc * (t_leg - tl)))).tolist()
    x_ref = (np.cumsum(v_ref) * h).tolist()
    wn = 40.0
    kv, ki, kp = J * wn, J * wn * wn / 4, wn / 4
    noise = (0.01 * rng.standard_normal(n // log_every + 1)).tolist()
    x = v = z = integ = u = x_prev = 0.0
    q_log, tau_log = [], []
    for i in range(n):
        if i % ctrl_every == 0:
            xm = math.floor(x / QUANTUM) * QUANTUM
            vm = (xm - x_prev) / (h * ctrl_every)
            x_prev = xm
            e = v_ref[i] + kp * (x_ref[i] - xm) - vm
            integ += ki * e * h * ctrl_every
            u = kv * e + integ
        if i % log_every == 0:
            q_log.append(math.floor(x / QUANTUM) * QUANTUM)
            tau_log.append(u + noise[len(tau_log)])
        g = FC + (FS - FC) * math.exp(-((v / VS) ** 2))
        a = sigma0 * abs(v) / g
        z = (z + h * v) / (1.0 + h * a)             # backward Euler in z with the old velocity
        f = sigma0 * z + sigma1 * (v - a * z)
        v = (v * J / h + u - f) / (J / h + FV)      # viscous term implicit
        x += v * h
    t_log = np.arange(len(q_log)) * h * log_every
    return Record(name=f"lugre_{bristle_quanta:g}", t_s=t_log, position=np.asarray(q_log), torque=np.asarray(tau_log))


@pytest.fixture(scope="module")
def stiff():
    return prepare(_lugre_sweep(0.2))


@pytest.fixture(scope="module")
def compliant():
    return prepare(_lugre_sweep(60.0))


def test_a_stick_swings_the_torque_through_the_static_band_at_the_turning_point(stiff):
    swings = reversal_dwell_swings(stiff)
    assert swings.size >= 6                         # 7 turns in 8 legs
    # the static band Fc + Fs = 2.3 N·m, less what the ramp leaves outside the dwell
    assert np.median(swings) >= 2.0 * FC, swings


@pytest.mark.parametrize("quanta", [10.0, 20.0, 60.0])
def test_a_bristle_changes_it_only_by_its_displacement(quanta):
    swings = reversal_dwell_swings(prepare(_lugre_sweep(quanta)))
    bound = 2.0 * (1.0 - math.exp(-(DWELL_QUANTA + 0.5) / quanta)) * FC
    assert swings.size >= 6
    assert np.median(swings) <= bound + 0.05, (swings, bound)   # 0.05: the noise after the median filter


def test_unquantised_position_gives_no_measurement():
    prep = prepare(_lugre_sweep(0.2, legs=3))
    assert reversal_dwell_swings(prep).size >= 1
    prep.position_resolution = 0.0                  # as for a record whose position is not quantised
    assert reversal_dwell_swings(prep).size == 0


def test_the_rule_refuses_a_bristle_on_the_stick_and_keeps_a_real_one(stiff, compliant):
    from plant.calibration.loop import _sticks_at_reversals, run_loop
    # a pre-sliding of 40 counts fitted to the stiff record: contradicted by its reversals
    cand = fit_model(stiff, ModelSpec(presliding_k=1.0 / (40 * QUANTUM)), refine=False)
    why = _sticks_at_reversals(cand, reversal_dwell_swings(stiff), stiff.position_resolution)
    assert why is not None and "sticks at its reversals" in why
    # fewer than two reversals: no verdict
    assert _sticks_at_reversals(cand, reversal_dwell_swings(stiff)[:1], stiff.position_resolution) is None
    # the real bristle of 60 counts is still named by the whole loop, and its candidate is not refused
    r = run_loop(compliant)
    assert "presliding" in [a.kind for a in r.accepted]
    assert not any("sticks at its reversals" in x["reason"] for x in r.rejected)


def test_blind_record_14278_no_longer_names_a_presliding(monkeypatch, tmp_path):
    """The record the rule was found on (used, clean, a sweep): named a pre-sliding before session 45.
    With the rule switched off the same loop names it again (the test can fail)."""
    import plant.calibration.loop as loop
    from plant.calibration.blind_records import make_record
    from plant.calibration.io import load_record

    make_record(14278).write_csv(tmp_path / "rec.csv")      # through a CSV, as the benchmark runs it
    prep = prepare(load_record(tmp_path / "rec.csv"))
    res = loop.run_loop(prep)
    assert [a.kind for a in res.accepted] == []
    assert any(x["kind"] == "presliding" and "sticks at its reversals" in x["reason"] for x in res.rejected)
    monkeypatch.setattr(loop, "STICK_SWING_OVER_FC", math.inf)
    assert "presliding" in [a.kind for a in loop.run_loop(prep).accepted]
