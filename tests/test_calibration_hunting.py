"""Hunting (stick-slip at one commanded speed) is found from the record alone and left out of the fit
(``plant.calibration.fit.hunting_mask``, session 44).

The records here come from the equations, with their own integrator, not from ``plant/`` or either
benchmark generator: a load on a spring (the drive's compliance) pulled by a motor that follows a
velocity staircase, with static friction above the kinetic one. Below the critical speed
``(Fs − Fc)/sqrt(k·J)`` the load sticks and slips (the classic spring-block); well above it it slides.
The log is the load's position through a quantising encoder and the spring's torque plus noise.
Without the static excess (``Fs = Fc``) the same staircase slides everywhere: nothing may be found.
"""
import numpy as np
import pytest

from plant.calibration.fit import hunting_mask, prepare
from plant.calibration.io import Record

#: The staircase: (duration [s], motor speed [rad/s]); fast stairs 13× above the critical speed,
#: slow ones 4.5× below it.
STAIRS = ((8.0, 0.03), (12.0, 5e-4), (12.0, -5e-4), (8.0, -0.03))


def _spring_block(fs_excess: float, seed: int = 0) -> Record:
    """Semi-implicit Euler at 10 kHz with an explicit stick state; logged at 1 kHz."""
    rng = np.random.default_rng(seed)
    j, k, c, fc = 0.5, 1000.0, 10.0, 0.3          # kg·m², N·m/rad, N·m·s/rad, N·m
    fs = fc + fs_excess
    dt, every = 1e-4, 10
    speeds = np.concatenate([np.full(int(round(d / dt)), v) for d, v in STAIRS])
    xm = np.cumsum(speeds) * dt
    x = v = 0.0
    stuck = True
    q_log, tau_log = [], []
    quantum = 2 * np.pi / 2**23
    for i, m in enumerate(xm):
        spring = k * (m - x)
        if stuck:
            if abs(spring) > fs:
                stuck = False
            else:
                v = 0.0
        if not stuck:
            a = (spring - c * v - fc * np.sign(v if v != 0.0 else spring)) / j
            v_new = v + a * dt
            if v != 0.0 and np.sign(v_new) != np.sign(v) and abs(spring) <= fs:
                v_new, stuck = 0.0, True
            v = v_new
            x += v * dt
        if i % every == 0:
            q_log.append(np.round(x / quantum) * quantum)
            tau_log.append(spring + 0.01 * rng.standard_normal())
    t = np.arange(len(q_log)) * dt * every
    return Record(name="spring_block", t_s=t, position=np.asarray(q_log), torque=np.asarray(tau_log))


def _stair_spans():
    ends = np.cumsum([d for d, _ in STAIRS])
    return [(e - d, e, v) for (d, v), e in zip(STAIRS, ends)]


def test_stick_slip_on_the_slow_stairs_is_found_and_left_out():
    prep = prepare(_spring_block(fs_excess=0.1))
    assert prep.hunting, "stick-slip on the slow stairs was not found"
    spans = _stair_spans()
    slow = [(a, b) for a, b, v in spans if abs(v) < 1e-2]
    fast = [(a, b) for a, b, v in spans if abs(v) > 1e-2]
    found = sum(max(0.0, min(b, y) - max(a, x)) for x, y in prep.hunting for a, b in slow)
    assert found >= 0.6 * sum(b - a for a, b in slow), (prep.hunting, slow)
    # nothing on a fast stair beyond the window's reach (1 s) across a stair's edge
    for x, y in prep.hunting:
        for a, b in fast:
            assert min(b - 1.0, y) - max(a + 1.0, x) <= 0.0, ((x, y), (a, b))
    # the hunting samples are not in the fit
    t_fit = prep.t_dec
    for x, y in prep.hunting:
        assert not np.any((t_fit > x + 0.05) & (t_fit < y - 0.05))


def test_the_same_staircase_without_stiction_has_no_hunting():
    prep = prepare(_spring_block(fs_excess=0.0))
    assert prep.hunting == []


@pytest.mark.parametrize("kind", ["steady", "step", "reversal", "sine", "noise", "ripple"])
def test_motions_that_do_not_hunt_are_not_flagged(kind):
    """Signals that are not stick-slip: a steady speed with noise, a speed step (1 → 0.55), a
    reversal, a sinusoidal motion, white velocity noise of the speed's size (spread 1.0 > 0.5, but
    a Gaussian sticks on at most 12.1 % of the samples) and a 3 Hz ripple of 0.7 × the speed that
    never stops the axis. Each of the rules (one speed, spread, sticking) must be able to refuse."""
    rng = np.random.default_rng(1)
    t = np.arange(0, 20, 0.01)
    w = {"steady": np.full(t.size, 1.0), "step": np.where(t < 10, 1.0, 0.55),
         "reversal": np.where(t < 10, 1.0, -1.0), "sine": np.sin(2 * np.pi * 0.2 * t),
         "noise": 1.0 + 0.95 * rng.standard_normal(t.size),
         "ripple": 1.0 + 0.7 * np.sin(2 * np.pi * 3.0 * t)}[kind]
    w = w + 0.05 * rng.standard_normal(t.size)
    assert not hunting_mask(t, w, v_still=0.02).any()


def test_a_stick_slip_velocity_is_flagged():
    """The positive control of the test above: bursts of 3× the mean speed for a third of each 0.3 s
    cycle, at rest otherwise."""
    t = np.arange(0, 20, 0.01)
    w = np.where((t % 0.3) < 0.1, 3.0, 0.0)
    assert hunting_mask(t, w, v_still=0.02).mean() > 0.9


def test_the_report_names_the_stretches_left_out(tmp_path):
    """``calibrate`` (through a CSV, as a user runs it) lists the hunting stretches in report.json's
    preprocessing and in report.md, so an engineer sees which part of the log the fit did not use."""
    import json

    from plant.calibration.report import calibrate

    rec = _spring_block(fs_excess=0.1)
    path = tmp_path / "spring_block.csv"
    np.savetxt(path, np.column_stack([rec.t_s, rec.torque, rec.position]), delimiter=",",
               header="time_s,torque_nm,position_rad", comments="")
    calibrate(path, tmp_path / "out", plots=False)
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    spans = report["preprocessing"]["hunting_s"]
    assert spans and all(8.0 <= a < b <= 32.0 for a, b in spans), spans
    assert "Hunting: the axis sticks and slips" in (tmp_path / "out" / "report.md").read_text()
    assert any(line.startswith("hunting:") for line in report["log"])
