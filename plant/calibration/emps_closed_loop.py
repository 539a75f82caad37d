"""Simulate the EMPS closed loop with a calibrated model and compare the drive force with the record.

Controller (EMPS README / description PDF eq. 6 and the authors' Simulink diagram), at 1 kHz::

    qf(k)   = 0.5 q(k) + 0.5 q(k−1)
    dq_m(k) = (qf(k) − qf(k−1)) / dt
    u(k)    = kv·(kp·(qg(k) − q(k)) − dq_m(k))       saturated to ±10 V
    vir(k)  = u(k−1)  (+ pulses(k) in the PULSES record, added after the saturation)
    force   = gtau·vir

Plant: one rigid mass, ``M·a = force − friction(v) − offset − Σ additive effects(q, t)``, integrated
with ``n_sub`` semi-implicit Euler sub-steps per sample (viscous term implicit; Coulomb by sign
with a stop at zero velocity when the net force cannot overcome it; with ``presliding`` the LuGre
bristle state replaces ``sign`` and is updated exactly; with ``backlash`` the friction acts only
while the motor pushes the load across a closed gap). The reference model's figure is 5.85 %
(``100·‖F − F_sim‖/‖F‖`` after the first 49 samples, benchmark script ``Simulation_EMPS``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from plant.calibration.fit import FitResult
from plant.calibration.io import Record
from plant.effects import Effect

__all__ = ["simulate_closed_loop", "force_error_pct", "model_from_fit"]


def model_from_fit(fit: FitResult, effects: list[Effect] | None = None, with_effects: bool = True) -> dict[str, Any]:
    """Plant coefficients for :func:`simulate_closed_loop` from a fit (+ its additive effects)."""
    p = fit.params()
    m: dict[str, Any] = {"mass": p["inertia"], "offset": p.get("offset", 0.0)}
    if "viscous" in p:
        m.update(fv_pos=p["viscous"], fv_neg=p["viscous"], fc_pos=p["coulomb"], fc_neg=p["coulomb"])
    else:
        m.update(fv_pos=p["viscous_pos"], fv_neg=p["viscous_neg"], fc_pos=p["coulomb_pos"], fc_neg=p["coulomb_neg"])
    m["stribeck"] = p.get("stribeck", 0.0)
    m["vs"] = fit.spec.stribeck_vs or 1.0
    m["presliding_k"] = fit.spec.presliding_k if with_effects else None
    m["sigma1"] = p.get("presliding_damping", 0.0)
    m["backlash_width"] = fit.spec.backlash_width if with_effects else None
    m["additive"] = [e for e in (effects or []) if e.additive] if with_effects else []
    return m


def simulate_closed_loop(record: Record, model: dict[str, Any], n_sub: int = 10, quantum_m: float = 0.0) -> dict[str, np.ndarray]:
    """Run the documented EMPS controller against ``model`` along the record's reference ``qg``.

    Parameters
    ----------
    record : Record
        An EMPS record (needs ``extra`` ``qg``, ``gtau``, ``kp``, ``kv``; ``pulses`` optional).
    model : dict
        From :func:`model_from_fit`.
    n_sub : int
        Integration sub-steps per 1 ms sample.
    quantum_m : float
        Encoder quantum applied to the measured position (0: none, as the reference simulation).

    Returns
    -------
    dict
        ``q`` [m], ``vir`` [V], ``force`` [N] (arrays like the record's).

    Raises
    ------
    ValueError
        Not an EMPS record.
    """
    ex = record.extra
    for key in ("qg", "gtau", "kp", "kv"):
        if key not in ex:
            raise ValueError(f"{record.source}: closed-loop simulation needs EMPS variable {key!r}")
    qg = np.asarray(ex["qg"], float)
    pulses = np.asarray(ex.get("pulses", np.zeros_like(qg)), float)
    gtau, kp, kv = float(ex["gtau"]), float(ex["kp"]), float(ex["kv"])
    dt = record.dt_s
    h = dt / n_sub
    M = float(model["mass"])
    fvp, fvn, fcp, fcn = (float(model[k]) for k in ("fv_pos", "fv_neg", "fc_pos", "fc_neg"))
    off = float(model["offset"])
    st, vs = float(model["stribeck"]), float(model["vs"])
    k_ps = model.get("presliding_k")
    sig1 = float(model.get("sigma1", 0.0)) if k_ps else 0.0
    additive = list(model.get("additive", []))
    bl = model.get("backlash_width") or 0.0
    hb = 0.5 * bl
    t = record.t_s
    n = t.size
    q = float(record.position[0])
    v = 0.0
    s_b = 0.0
    yl = q  # load position behind the backlash (centred in the gap at the start)
    q_meas_prev = q
    qf_prev = q
    u_prev = 0.0
    q_out = np.empty(n)
    vir = np.empty(n)

    def coul(vel: float) -> tuple[float, float]:
        # Coulomb (+ Stribeck) magnitude for the direction of vel
        fc = fcp if vel > 0 else fcn
        return fc, st * math.exp(-((vel / vs) ** 2))

    for k in range(n):
        qm = q if quantum_m <= 0 else round(q / quantum_m) * quantum_m
        if k == 0:
            q_meas_prev, qf_prev = qm, qm
        qf = 0.5 * qm + 0.5 * q_meas_prev
        dq_m = (qf - qf_prev) / dt
        u = kv * (kp * (qg[k] - qm) - dq_m)
        u = 10.0 if u > 10.0 else (-10.0 if u < -10.0 else u)
        applied = u_prev + pulses[k]
        vir[k] = applied
        q_out[k] = q
        force = gtau * applied
        t0 = t[k]
        for j in range(n_sub):
            ts = t0 + j * h
            load = off
            for e in additive:
                load += e.torque_nm(q, v, ts)
            if k_ps:
                sgn = 1.0 if v > 0 else (-1.0 if v < 0 else 0.0)
                fc, sx = coul(v if v != 0 else s_b)
                ff = (fc + sx * 1.0) * s_b + sig1 * (v - abs(v) * s_b)
                fv = fvp if v > 0 else fvn
                v_new = (v + h / M * (force - load - ff)) / (1.0 + h * fv / M)
                s_b = sgn + (s_b - sgn) * math.exp(-k_ps * abs(v) * h) if v != 0 else s_b
                q += 0.5 * (v + v_new) * h
                v = v_new
                continue
            drive = force - load
            if bl > 0.0:
                d = q - yl
                eng = 1.0 if d >= hb * (1 - 1e-9) else (-1.0 if d <= -hb * (1 - 1e-9) else 0.0)
                pushing = (v * eng > 0.0) or (v == 0.0 and drive * eng > 0.0)
                if not pushing:
                    # inside the gap: the load (and its friction) is not felt
                    v_new = v + h / M * drive
                    q += 0.5 * (v + v_new) * h
                    v = v_new
                    if q - yl > hb:
                        yl = q - hb
                    elif q - yl < -hb:
                        yl = q + hb
                    continue
            if v == 0.0:
                fc0, _ = coul(drive)
                if abs(drive) <= fc0 + st:
                    continue
                sgn = 1.0 if drive > 0 else -1.0
            else:
                sgn = 1.0 if v > 0 else -1.0
            fc, sx = coul(sgn)
            fv = fvp if sgn > 0 else fvn
            v_new = (v + h / M * (drive - sgn * (fc + sx))) / (1.0 + h * fv / M)
            if v != 0.0 and v_new * v < 0.0:
                v_new = 0.0
            q += 0.5 * (v + v_new) * h
            v = v_new
            if bl > 0.0:
                if q - yl > hb:
                    yl = q - hb
                elif q - yl < -hb:
                    yl = q + hb
        q_meas_prev, qf_prev, u_prev = qm, qf, u
    return {"q": q_out, "vir": vir, "force": gtau * vir}


def force_error_pct(record: Record, sim: dict[str, np.ndarray], n_border: int = 49) -> float:
    """``100·‖F − F_sim‖/‖F‖`` over samples ``n_border:`` (the benchmark's relative force error)."""
    F = record.torque[n_border:]
    return float(100.0 * np.linalg.norm(F - sim["force"][n_border:]) / np.linalg.norm(F))
