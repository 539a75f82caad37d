"""NOT KEPT (a tie on never-used 27660-27759; kept here as written, outside pytest's testpaths; it needs the
change in `change.diff` and fails on main). The pair step (issue 7, session 60; docs/calibration.md "Session 60"): where no candidate passes alone, the
two largest gains among gravity and position lines that only the rank test refused are fitted together, and
both are named if the pair predicts held-out blocks better and each still predicts beside the other.

The records are written here from the equations (open loop: the torque is computed from a prescribed
tracking-like motion, one slow leg out and back over 2.4 rad; no code of ``plant/`` makes them), the position
quantised like an encoder. Over that travel a gravity (one cycle per 2π) and a position line of 2.8 cycles share
the residual: either alone leaves the other's part in it, its held-out gain lies in too few of the rank test's
batches, and before the pair step the loop named neither (used independent records 27032 and 27092 are such
tracking records).
"""

import math

import numpy as np
import pytest

from plant.calibration import loop
from plant.calibration.fit import prepare
from plant.calibration.io import Record

FS_HZ = 500.0
COUNTS_PER_RAD = 2**20 / (2 * math.pi)
J = 7.0                       # kg·m²
GRAVITY_NM = 4.0
LINE_NM, PERIOD_RAD = 1.4, 0.845


def _tracking(span: float = 2.4, v: float = 0.14, accel_s: float = 1.0) -> np.ndarray:
    """Velocity [rad/s]: a rest, a 1 s ramp, one leg at ``v`` over ``span``, a ramp down, a rest, the leg back."""
    n_acc = int(accel_s * FS_HZ)
    ramp = np.linspace(0.0, v, n_acc)
    hold = np.full(int((span / v - accel_s) * FS_HZ), v)
    rest = np.zeros(int(1.0 * FS_HZ))
    leg = np.concatenate([ramp, hold, ramp[::-1]])
    return np.concatenate([rest, leg, rest, -leg, rest])


def _record(gravity_nm: float = GRAVITY_NM, line_nm: float = LINE_NM, seed: int = 0) -> Record:
    """A rigid axis (J 7 kg·m², viscous 8 N·m·s/rad, Coulomb 3.4 N·m, offset 0.35 N·m) with a gravity of
    ``gravity_nm`` and a position line of ``line_nm`` at 0.845 rad; torque noise 0.04 N·m; 2^20 counts/rev."""
    v = _tracking()
    dt = 1.0 / FS_HZ
    t = np.arange(v.size) * dt
    q = 0.3 + np.cumsum(v) * dt
    tau = (J * np.gradient(v, dt) + 8.0 * v + 3.4 * np.tanh(v / 1e-3) + 0.35
           + gravity_nm * np.sin(q + 2.8) + line_nm * np.sin(2 * math.pi * q / PERIOD_RAD - 1.1))
    tau = tau + np.random.default_rng(seed).normal(0.0, 0.04, t.size)
    return Record(name="rec", t_s=t, position=np.floor(q * COUNTS_PER_RAD) / COUNTS_PER_RAD, torque=tau)


@pytest.fixture(scope="module")
def both():
    return loop.run_loop(prepare(_record()))


def test_neither_passes_alone(both):
    """The premise: at step 1 the best gravity and the best position line each predict held-out blocks better by
    over 40 % but with z under 3 (the level is 3.6); named, they are no longer listed as refused at that step."""
    step1 = [line for line in both.log if line.startswith("step 1 candidates")][0]
    entries = [p.rsplit(" z=", 1) for p in step1.split(": ", 1)[1].split("; ")]
    best = {}
    for head, z in entries:
        kind, gain = head.split()[0], float(head.split()[1])
        if kind not in best or gain > best[kind][0]:
            best[kind] = (gain, float(z))
    for kind in ("gravity_imbalance", "position_periodic"):
        assert best[kind][0] > 40.0 and best[kind][1] < 3.0, step1
    assert not any(r["kind"] == "gravity_imbalance" for r in both.rejected), both.rejected


def test_the_pair_is_named_with_its_parameters(both):
    assert [e.kind for e in both.accepted] == ["gravity_imbalance", "position_periodic"], both.log
    f = both.final
    assert math.hypot(f.param("grav_sin"), f.param("grav_cos")) == pytest.approx(GRAVITY_NM, rel=0.05)
    assert f.spec.position_periods[0] == pytest.approx(PERIOD_RAD, rel=0.01)
    assert math.hypot(f.param("pos0_sin"), f.param("pos0_cos")) == pytest.approx(LINE_NM, rel=0.05)
    note = [line for line in both.log if "pair step" in line and "both added" in line]
    assert note and "beside" in note[0]
    for e in both.accepted:
        assert "Named together with" in e.evidence and e.cv_z >= 3.6, e.evidence


@pytest.mark.parametrize("gravity_nm, line_nm, kind", [(GRAVITY_NM, 0.0, "gravity_imbalance"),
                                                      (0.0, LINE_NM, "position_periodic")])
def test_one_effect_alone_is_named_alone(gravity_nm, line_nm, kind):
    """Either term alone passes on its own; the pair step does not add the other."""
    res = loop.run_loop(prepare(_record(gravity_nm, line_nm)))
    assert [e.kind for e in res.accepted] == [kind], res.log
    assert not any("both added" in line for line in res.log)


def test_a_clean_tracking_record_gets_no_pair():
    res = loop.run_loop(prepare(_record(0.0, 0.0)))
    assert [e.kind for e in res.accepted] == [], res.log
    assert not any("both added" in line for line in res.log)
