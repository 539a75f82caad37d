"""A line at an alias of the encoder's count rate (issue 7, session 40; docs/calibration.md
"Session 40").

A velocity loop that differences quantised encoder counts sees a quantisation error that is a
sawtooth in the position, one period per count; at a constant speed it turns that into torque at
the count rate ``r`` and its harmonics, and a log that samples the torque without an anti-alias
filter folds them to ``|k·r − m·fs|``. The records here are written in the test from the equations,
with their own chain — not the independent generator's (``floor`` counts, a filtered velocity at
1 kHz, every 4th tick logged) on which the effect was found: a rigid axis under a PI velocity loop at
2 kHz acting on *rounded* counts differenced over one tick, the torque logged every 8th tick (250 Hz),
the position logged as counts. Nothing of ``plant/`` makes them.
"""

import math

import numpy as np
import pytest

from plant.calibration import loop
from plant.calibration.fit import prepare
from plant.calibration.io import Record

CTRL_HZ = 2000.0
LOG_EVERY = 8
FS_LOG_HZ = CTRL_HZ / LOG_EVERY
COUNTS_PER_RAD = 2**20 / (2 * math.pi)
#: the pass speed: its count rate's first alias folded by the 250 Hz log falls at 3.1 Hz — inside the
#: loop's fit band (an alias above it is filtered away before the fit) and low enough that its torque,
#: read as the inertial torque of a motion, is a displacement of more than 10 quanta (at 7.3 Hz it is
#: 8 quanta, and the resolution rule of session 19 refuses it already: the test would be empty)
ALIAS_HZ = 3.1
SPEED_RAD_S = (FS_LOG_HZ * 66 + ALIAS_HZ) / COUNTS_PER_RAD


def _sweep(speed=SPEED_RAD_S, passes=4, pass_s=15.0, ramp_s=0.5, rest_s=0.5):
    """Velocity set-point [rad/s] at the controller rate: passes back and forth at one speed."""
    ramp = np.linspace(0.0, 1.0, int(ramp_s * CTRL_HZ))
    segs = [np.zeros(int(rest_s * CTRL_HZ))]
    for k in range(passes):
        s = speed if k % 2 == 0 else -speed
        segs += [s * ramp, np.full(int(pass_s * CTRL_HZ), s), s * ramp[::-1], np.zeros(int(rest_s * CTRL_HZ))]
    return np.concatenate(segs)


def _record(v_ref, ripple=None, seed=5):
    """Closed loop: J 1.5 kg·m², viscous 8 N·m·s/rad, Coulomb 2 N·m (tanh, 1e-4 rad/s); PI (kp 40,
    ki 800) on rounded counts; 4 semi-implicit Euler substeps per tick; optional position ripple
    ``(A [N·m], period [rad])``; torque noise 0.02 N·m on the log."""
    j, fv, fc, kp, ki, n_sub = 1.5, 8.0, 2.0, 40.0, 800.0, 4
    dt = 1.0 / CTRL_HZ
    h = dt / n_sub
    th = w = integ = 0.0
    cnt_prev = 0
    tq_log, pos_log = [], []
    for i, vr in enumerate(v_ref.tolist()):
        cnt = round(th * COUNTS_PER_RAD)
        v_est = (cnt - cnt_prev) / (COUNTS_PER_RAD * dt) if i else 0.0
        cnt_prev = cnt
        e = vr - v_est
        integ += ki * e * dt
        u = kp * e + integ
        if i % LOG_EVERY == 0:
            tq_log.append(u)
            pos_log.append(cnt / COUNTS_PER_RAD)
        for _ in range(n_sub):
            load = fv * w + fc * math.tanh(w / 1e-4)
            if ripple is not None:
                load += ripple[0] * math.sin(2 * math.pi * th / ripple[1] + 0.7)
            w += h * (u - load) / j
            th += h * w
    tq = np.asarray(tq_log) + np.random.default_rng(seed).normal(0.0, 0.02, len(tq_log))
    t = np.arange(tq.size) / FS_LOG_HZ
    return Record(name="alias", t_s=t, position=np.asarray(pos_log), torque=tq)


def _lines(res):
    return [e for e in res.effects() if e.kind in ("time_periodic", "position_periodic")]


@pytest.fixture(scope="module")
def clean():
    return prepare(_record(_sweep()))


def test_the_quantum_is_refined_from_the_log():
    """The smallest step read from a log is ~1e-8 off (printed digits); the refined quantum is the
    encoder's to 1e-9, and an unquantised position gives None."""
    x = np.round(np.linspace(0.0, 2.0, 40001) * COUNTS_PER_RAD) / COUNTS_PER_RAD
    rough = float(np.float32(1.0 / COUNTS_PER_RAD))
    q = loop.position_quantum(x, rough)
    assert q == pytest.approx(1.0 / COUNTS_PER_RAD, rel=1e-9)
    assert abs(rough * COUNTS_PER_RAD - 1.0) > 1e-8
    assert loop.position_quantum(np.linspace(0.0, 2.0, 40001) + 1e-7 * np.sin(np.arange(40001)), rough) is None


def test_the_runs_carry_the_count_rate(clean):
    """Four passes are found, each at the set-point's count rate."""
    runs, q = loop.constant_speed_runs(clean)
    assert q == pytest.approx(1.0 / COUNTS_PER_RAD, rel=1e-9)
    assert len(runs) == 4
    for r, d in runs:
        assert r == pytest.approx(SPEED_RAD_S * COUNTS_PER_RAD, rel=1e-6)
        assert d > 10.0


def test_an_alias_of_the_count_rate_is_not_named(clean):
    """Without the test a line at the alias is named (the defect); with it none, and the refusal
    names the alias."""
    off = loop.run_loop(clean, cfg=loop.LoopConfig(count_alias_guard=False))
    named = _lines(off)
    assert named, "the record no longer shows the defect the test is for"
    for e in named:
        f = e.frequency_hz if e.kind == "time_periodic" else SPEED_RAD_S / e.period_rad
        k = round(f / ALIAS_HZ)
        assert 1 <= k <= loop.COUNT_ALIAS_HARMONICS and f == pytest.approx(k * ALIAS_HZ, abs=0.1)
    res = loop.run_loop(clean)
    assert not _lines(res), [e.params() for e in _lines(res)]
    assert any("alias of the encoder's count rate" in r["reason"] for r in res.rejected)
    # the structure stays in `unexplained`, and its note says what it is
    at_alias = [u for u in res.unexplained if "alias of the encoder's count rate" in u.get("note", "")]
    assert at_alias, res.unexplained
    for u in at_alias:
        f = u["frequency"] if u["domain"] == "time" else SPEED_RAD_S * u["frequency"]
        assert f == pytest.approx(round(f / ALIAS_HZ) * ALIAS_HZ, abs=0.1)


def test_a_real_ripple_on_the_same_motion_is_still_named():
    """A 0.3 N·m position ripple of period 0.021 rad (4.2 Hz at the pass speed, away from the
    aliases) beside the alias: named within 3 % (period) and 30 % (amplitude)."""
    res = loop.run_loop(prepare(_record(_sweep(), ripple=(0.3, 0.021))))
    pos = [e for e in _lines(res) if e.kind == "position_periodic"]
    assert len(pos) == 1, [e.params() for e in _lines(res)]
    assert pos[0].period_rad == pytest.approx(0.021, rel=0.03)
    assert pos[0].amplitude_nm == pytest.approx(0.3, rel=0.3)
    assert not [e for e in _lines(res) if e.kind == "time_periodic"]
