"""The decimated time base and the line-resolution rule (issue 7, session 19; docs/calibration.md
"Session 19").

- The decimation filter is normalised to unit DC gain and the time base is sampled, not filtered:
  before, the decimated time axis was 1.145 % short and a time line with more than ≈ 175 cycles in
  the record could not be reached by the frequency refinement.
- A time or position line whose amplitude, as the inertial torque of a motion (``A/(J·ω²)``), moves
  the axis by under ``MIN_TRANSITION_COUNTS`` position quanta is not added, unless a position line
  lies at a declared period of the drive.

The records are written here from the equations (open loop: the torque is computed from a
prescribed motion; no code of ``plant/`` makes them), with the position quantised like an encoder.
"""

import math

import numpy as np
import pytest

from plant.calibration import loop
from plant.calibration import residuals as res
from plant.calibration.fit import prepare
from plant.calibration.io import Record

FS_HZ = 500.0                            # decimation 5 (the fit sees 100 Hz)
COUNTS_PER_RAD = 2**20 / (2 * math.pi)
Q_RAD = 1.0 / COUNTS_PER_RAD             # one position quantum
J = 2.0                                  # kg·m²


def _staircase() -> np.ndarray:
    """Velocity [rad/s]: log-spaced levels 0.013…0.4 rad/s, each way, 4 s per level (≈ 60 s)."""
    segs = [np.zeros(int(0.5 * FS_HZ))]
    for v in 0.4 * np.logspace(-1.5, 0.0, 6):
        ramp = np.linspace(0, v, int(0.2 * FS_HZ))
        hold = np.full(int(4.0 * FS_HZ), v)
        segs += [ramp, hold, ramp[::-1], -ramp, -hold, -ramp[::-1]]
    segs.append(np.zeros(int(0.5 * FS_HZ)))
    return np.concatenate(segs)


def _record(torque_extra=None, seed: int = 0) -> Record:
    """A rigid axis (J 2 kg·m², viscous 5 N·m·s/rad, Coulomb 3 N·m, offset 0.5 N·m) on the
    staircase; torque noise 0.05 N·m; a 2^20-count encoder."""
    v = _staircase()
    dt = 1.0 / FS_HZ
    t = np.arange(v.size) * dt
    q = np.cumsum(v) * dt
    tau = J * np.gradient(v, dt) + 5.0 * v + 3.0 * np.tanh(v / 1e-3) + 0.5
    if torque_extra is not None:
        tau = tau + torque_extra(t, q)
    tau = tau + np.random.default_rng(seed).normal(0.0, 0.05, t.size)
    return Record(name="rec", t_s=t, position=np.floor(q * COUNTS_PER_RAD) / COUNTS_PER_RAD, torque=tau)


def _amplitude_for_quanta(quanta: float, f_hz: float) -> float:
    """The torque amplitude [N·m] whose inertial motion ``A/(J·ω²)`` is ``quanta`` position quanta."""
    return quanta * Q_RAD * J * (2 * math.pi * f_hz) ** 2


def test_decimated_time_and_position_are_not_scaled():
    """t_dec are full-rate time stamps (sampled, not filtered), and a decimated position equals the
    full-rate one at those rows; the unnormalised filter (DC gain 0.98855) had both 1.145 % low."""
    prep = prepare(_record())
    assert prep.decim == 5
    rows = np.searchsorted(prep.t, prep.t_dec - 1e-9)
    assert np.array_equal(prep.t[rows], prep.t_dec)
    mid = slice(prep.t_dec.size // 4, 3 * prep.t_dec.size // 4)
    assert np.allclose(prep.q_dec[mid], prep.q[rows][mid], rtol=0, atol=1e-4 * np.ptp(prep.q))


def test_a_line_with_many_cycles_is_found_at_its_frequency():
    """A 6 Hz line has ≈ 360 cycles in the record: with the time axis 1.145 % short its candidate
    was built 2 bins beyond the refinement's reach and refused."""
    a = _amplitude_for_quanta(75.0, 6.0)
    rec = _record(lambda t, q: a * np.sin(2 * math.pi * 6.0 * t + 0.3))
    res = loop.run_loop(prepare(rec))
    kinds = [e.kind for e in res.accepted]
    assert kinds == ["time_periodic"], kinds
    f = res.final.spec.time_frequencies[0]
    assert f == pytest.approx(6.0, rel=1e-4)


def test_a_line_of_a_few_quanta_is_not_added_and_says_why():
    """The same amplitude at 30 Hz is a motion of 3 quanta: not named, the refusal says so, and
    the unexplained peak's note names the measurement chain."""
    a = _amplitude_for_quanta(75.0, 6.0)      # 3 quanta at 30 Hz
    rec = _record(lambda t, q: a * np.sin(2 * math.pi * 30.0 * t + 0.3))
    res = loop.run_loop(prepare(rec))
    assert "time_periodic" not in [e.kind for e in res.accepted]
    why = [r["reason"] for r in res.rejected if r["kind"] == "time_periodic" and "position quanta" in r["reason"]]
    assert why and "3 position quanta" in why[0], res.rejected
    peaks = [u for u in res.unexplained if u["domain"] == "time" and u.get("frequency")
             and abs(u["frequency"] - 30.0) < 0.1]
    assert peaks and "measurement chain" in peaks[0]["note"]


def test_a_declared_drive_period_exempts_a_position_line():
    """A position line of a few quanta at the record's median speed is named only when its period
    is declared as one of the drive's; a declared period elsewhere does not help."""
    period = 0.004                                             # rad
    prep0 = prepare(_record())
    mov = res.moving_mask(prep0.dq_dec)                       # the loop's typical speed: median moving |dq|
    speed = float(np.median(np.abs(prep0.dq_dec[mov])))
    a = _amplitude_for_quanta(3.0, speed / period)
    rec = _record(lambda t, q: a * np.sin(2 * math.pi * q / period + 1.0))
    prep = prepare(rec)
    plain = loop.run_loop(prep)
    assert "position_periodic" not in [e.kind for e in plain.accepted]
    assert any(r["kind"] == "position_periodic" and "position quanta" in r["reason"] for r in plain.rejected)
    other = loop.run_loop(prep, cfg=loop.LoopConfig(drive_periods=(2.5 * period,)))
    assert "position_periodic" not in [e.kind for e in other.accepted]
    declared = loop.run_loop(prep, cfg=loop.LoopConfig(drive_periods=(period,)))
    assert [e.kind for e in declared.accepted] == ["position_periodic"]
    assert declared.final.spec.position_periods[0] == pytest.approx(period, rel=0.01)


def test_drive_periods_option_errors_name_the_item():
    from host.cli_calibrate import parse_periods

    assert parse_periods("0.0025, 0.1") == (0.0025, 0.1)
    for bad in ("x", "0", "-1", "inf", ""):
        with pytest.raises(ValueError, match="--drive-periods: expected comma-separated positive periods"):
            parse_periods(f"0.1,{bad}")
