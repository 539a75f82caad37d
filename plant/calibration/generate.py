"""Synthetic calibration records with an *undeclared* effect, for testing the calibration loop.

A record is made by simulating one rigid rotary axis (inertia, viscous + Coulomb friction, a
constant load offset) on the trajectory a real calibration run uses: a velocity staircase in the
positive direction (0.05 → 0.8 rad/s), the same back in the negative direction, and a slow
back-and-forth segment with several velocity reversals. A discrete 1 kHz position controller
(PD with acceleration feed-forward, one-sample output delay) computes the drive torque from the
quantized encoder position; the record holds that torque (averaged over the sample interval
centred on each sample, as a filtered current measurement would be) plus measurement noise, and the
quantized position — what a drive's own log would hold.

One effect is switched on (``effect``), which the fit is not told about:

* a kind of :mod:`plant.effects` (``asymmetric_friction``, ``position_periodic``,
  ``gravity_imbalance``, ``presliding``, ``backlash``, ``time_periodic``), with the defaults in
  :data:`DEFAULT_EFFECTS` or ``params`` overrides;
* ``"none"``: a clean record;
* ``"delay"``: outside the library — the logged position lags the torque by ``delay_s``
  (default 8 ms), as with an unsynchronised logger.

Why not :class:`plant.axis.AxisPlant`: it is driven by PWM duties through two motors and two
backlash gear trains, so the torque at the axis is not an input one can log directly, and its
twin-train backlash would be present in every record. This generator is a single rigid axis with
the same effect objects (:mod:`plant.effects`; ``presliding`` as the LuGre bristle state with
σ0, σ1; ``backlash`` as a play operator between motor and load friction), which is what the
calibration model assumes. Pure Python + NumPy, deterministic for a given ``seed``.

Usage::

    schmidt-fil generate-record --effect position_periodic --param period_rad=0.1 --out rec.csv
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from plant.calibration.io import Record
from plant.effects import EFFECT_KINDS, build_effect

__all__ = ["BASELINE", "DEFAULT_EFFECTS", "generate_record", "parse_params", "staircase"]

#: Baseline axis of the generator (SI).
BASELINE: dict[str, float] = {
    "inertia_kg_m2": 2.0,
    "viscous_nm_s_rad": 5.0,
    "coulomb_nm": 3.0,
    "offset_nm": 0.5,
    "torque_noise_nm": 0.05,
    "encoder_counts_per_rev": 2.0**20,
    "dt_s": 1e-3,
}

#: Default parameters of the undeclared effect, per kind.
DEFAULT_EFFECTS: dict[str, dict[str, float]] = {
    "asymmetric_friction": {"viscous_pos_nm_s_rad": 4.0, "viscous_neg_nm_s_rad": 6.5, "coulomb_pos_nm": 2.6, "coulomb_neg_nm": 3.4},
    "position_periodic": {"period_rad": 0.1, "amplitude_nm": 0.4, "phase_rad": 0.7},
    "gravity_imbalance": {"amplitude_nm": 1.5, "phase_rad": 0.3},
    "presliding": {"sigma0_nm_rad": 1500.0, "sigma1_nm_s_rad": 5.0},
    "backlash": {"width_rad": 0.004},
    "time_periodic": {"frequency_hz": 7.3, "amplitude_nm": 0.3, "phase_rad": 1.0},
    "delay": {"delay_s": 0.008},
}
if set(DEFAULT_EFFECTS) - {"delay"} != set(EFFECT_KINDS):  # pragma: no cover - a new kind needs its defaults here
    raise ImportError(f"generate.DEFAULT_EFFECTS covers {sorted(DEFAULT_EFFECTS)}; plant.effects has {sorted(EFFECT_KINDS)}")


def parse_params(text: str | None) -> dict[str, float]:
    """Parse ``"a=1,b=2"`` into ``{"a": 1.0, "b": 2.0}``.

    Raises
    ------
    ValueError
        Malformed item or a non-numeric value.
    """
    out: dict[str, float] = {}
    for item in (text or "").split(","):
        item = item.strip()
        if not item:
            continue
        if "=" not in item:
            raise ValueError(f"--param item {item!r} must look like name=value")
        k, v = item.split("=", 1)
        try:
            out[k.strip()] = float(v)
        except ValueError:
            raise ValueError(f"--param {k.strip()!r}: expected a number, got {v!r}") from None
    return out


def staircase(dt_s: float = 1e-3) -> tuple[np.ndarray, np.ndarray]:
    """Reference velocity [rad/s] and time [s] of the calibration trajectory.

    Levels 0.05, 0.1, 0.2, 0.4, 0.8 rad/s for 1.5 s each, up then down; the negative staircase
    back; then a 0.8 Hz back-and-forth (±0.15 rad/s) for 4 s — 7 reversals. Transitions are
    0.1 s cosine ramps, so the acceleration is finite.
    """
    levels = [0.05, 0.1, 0.2, 0.4, 0.8]
    seg: list[tuple[float, float]] = [(0.0, 0.5)]
    seg += [(v, 1.5) for v in levels] + [(0.0, 0.5)]
    seg += [(-v, 1.5) for v in levels] + [(0.0, 0.5)]
    t_end = sum(d for _, d in seg) + 4.0 + 0.5
    t = np.arange(0.0, t_end, dt_s)
    v = np.zeros_like(t)
    t0 = 0.0
    prev = 0.0
    ramp = 0.1
    for level, dur in seg:
        m = (t >= t0) & (t < t0 + dur)
        x = np.clip((t[m] - t0) / ramp, 0, 1)
        v[m] = prev + (level - prev) * 0.5 * (1 - np.cos(np.pi * x))
        prev = level
        t0 += dur
    m = (t >= t0) & (t < t0 + 4.0)
    v[m] = prev + 0.15 * np.sin(2 * np.pi * 0.8 * (t[m] - t0))
    return t, v


def generate_record(
    effect: str = "none",
    params: dict[str, float] | None = None,
    seed: int = 0,
    duration_s: float | None = None,
) -> Record:
    """Simulate a calibration record with one undeclared effect.

    Parameters
    ----------
    effect : str
        ``"none"``, ``"delay"`` or an effect kind.
    params : dict, optional
        Overrides of :data:`DEFAULT_EFFECTS` for that effect.
    seed : int
        Noise seed.
    duration_s : float, optional
        Truncate the trajectory.

    Returns
    -------
    Record
        Rotary record; ``extra["truth"]`` holds the effect spec (or ``None``).

    Raises
    ------
    ValueError
        Unknown effect or parameter.
    """
    valid = ["none", "delay", *EFFECT_KINDS]
    if effect not in valid:
        raise ValueError(f"unknown effect {effect!r}; valid: {valid}")
    spec: dict[str, Any] | None = None
    delay_s = 0.0
    if effect == "delay":
        p = {**DEFAULT_EFFECTS["delay"], **(params or {})}
        bad = set(p) - {"delay_s"}
        if bad:
            raise ValueError(f"effect 'delay': unknown parameter(s) {sorted(bad)}; valid: ['delay_s']")
        delay_s = float(p["delay_s"])
        spec = {"kind": "delay", "delay_s": delay_s}
    elif effect != "none":
        spec = {"kind": effect, **DEFAULT_EFFECTS[effect], **(params or {})}
        build_effect(spec)  # validates
    eff = build_effect(spec) if spec and effect != "delay" else None
    B = BASELINE
    dt = B["dt_s"]
    t, v_ref = staircase(dt)
    if duration_s is not None:
        keep = t < duration_s
        t, v_ref = t[keep], v_ref[keep]
    q_ref = np.cumsum(v_ref) * dt
    a_ref = np.gradient(v_ref, dt)
    J = B["inertia_kg_m2"]
    fv_p = fv_n = B["viscous_nm_s_rad"]
    fc_p = fc_n = B["coulomb_nm"]
    off = B["offset_nm"]
    if eff is not None and eff.kind == "asymmetric_friction":
        fv_p, fv_n, fc_p, fc_n = eff.viscous_pos_nm_s_rad, eff.viscous_neg_nm_s_rad, eff.coulomb_pos_nm, eff.coulomb_neg_nm
        off = 0.0  # the asymmetric Coulomb levels carry any constant part
    k_ps = sig1 = 0.0
    if eff is not None and eff.kind == "presliding":
        k_ps, sig1 = eff.sigma0_nm_rad / B["coulomb_nm"], eff.sigma1_nm_s_rad
    hb = 0.5 * eff.width_rad if eff is not None and eff.kind == "backlash" else 0.0
    additive = eff if eff is not None and eff.additive else None
    quantum = 2 * math.pi / B["encoder_counts_per_rev"]
    # controller: critically damped PD around the reference + feed-forward
    wn = 2 * math.pi * 8.0
    kp, kd = J * wn * wn, 2 * J * wn
    n_sub = 5
    h = dt / n_sub
    n = t.size
    q = v = 0.0
    s_b = 0.0
    yl = 0.0
    u_prev = 0.0
    q_meas = np.empty(n)
    tau = np.empty(n)
    qm_prev = 0.0
    for k in range(n):
        qm = round(q / quantum) * quantum
        q_meas[k] = qm
        vm = (qm - qm_prev) / dt if k else 0.0
        u = J * a_ref[k] + kp * (q_ref[k] - qm) + kd * (v_ref[k] - vm)
        applied = u_prev
        tau[k] = applied
        for j in range(n_sub):
            ts = t[k] + j * h
            load = off + (additive.torque_nm(q, v, ts) if additive is not None else 0.0)
            drive = applied - load
            if k_ps:
                sgn = 1.0 if v > 0 else (-1.0 if v < 0 else 0.0)
                ff = fc_p * s_b + sig1 * (v - abs(v) * s_b)
                v_new = (v + h / J * (drive - ff)) / (1.0 + h * fv_p / J)
                if v != 0:
                    s_b = sgn + (s_b - sgn) * math.exp(-k_ps * abs(v) * h)
                q += 0.5 * (v + v_new) * h
                v = v_new
                continue
            if hb > 0.0:
                d = q - yl
                eng = 1.0 if d >= hb * (1 - 1e-9) else (-1.0 if d <= -hb * (1 - 1e-9) else 0.0)
                if not ((v * eng > 0.0) or (v == 0.0 and drive * eng > 0.0)):
                    v_new = v + h / J * drive
                    q += 0.5 * (v + v_new) * h
                    v = v_new
                    yl = q - hb if q - yl > hb else (q + hb if q - yl < -hb else yl)
                    continue
            if v == 0.0:
                if abs(drive) <= (fc_p if drive > 0 else fc_n):
                    continue
                sgn = 1.0 if drive > 0 else -1.0
            else:
                sgn = 1.0 if v > 0 else -1.0
            fc = fc_p if sgn > 0 else fc_n
            fv = fv_p if sgn > 0 else fv_n
            v_new = (v + h / J * (drive - sgn * fc)) / (1.0 + h * fv / J)
            if v != 0.0 and v_new * v < 0.0:
                v_new = 0.0
            q += 0.5 * (v + v_new) * h
            v = v_new
            if hb > 0.0:
                yl = q - hb if q - yl > hb else (q + hb if q - yl < -hb else yl)
        qm_prev = qm
        u_prev = u
    rng = np.random.default_rng(seed)
    # the logged torque is the drive torque averaged over the sample interval centred on t_k
    # (as a current ADC with an anti-alias filter would log it): tau[k] acts over [t_k, t_k+1)
    logged = 0.5 * (tau + np.concatenate([[tau[0]], tau[:-1]]))
    torque = logged + rng.normal(0.0, B["torque_noise_nm"], n)
    position = q_meas
    if delay_s > 0:
        d = int(round(delay_s / dt))
        position = np.concatenate([np.full(d, q_meas[0]), q_meas[:-d]])
    return Record(
        name=f"generated-{effect}", t_s=t, position=position, torque=torque, linear=False,
        source=f"plant.calibration.generate(effect={effect!r}, seed={seed})",
        extra={"format": "generated", "truth": spec, "baseline": dict(B)},
    )
