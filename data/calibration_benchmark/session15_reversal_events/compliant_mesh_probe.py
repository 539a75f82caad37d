"""Session 15 probe: a play with a compliant mesh (quasi-static: gap b, then a linear spring ramp of
displacement d = Fc/k up to the load's breakaway), whose rigid limit d → 0 is the play itself.

The transmitted torque of a dead zone b/2 in series with a spring k driving a load with Coulomb
friction Fc, load inertia neglected, is Fc·clip(deadzone(s, b/2)/d, −1, 1) with s = q − play(q, b + 2d)
and d = Fc/k: zero inside the gap, a ramp over the wind-up, ±Fc once the load slides. The load moves
with play(q, b + 2d). The loop's play alone is the limit d → 0. Encoded for this probe in the
existing slots (backlash_width = b, presliding_k = 1/d); ``design_full`` below is the package's
with that case added, patched in at run time (the package is unchanged).
Usage: python compliant_mesh_probe.py OUT.json SEED...   (backlash-only records)
"""
import dataclasses, json, math, os, sys, tempfile, pathlib
from concurrent.futures import ProcessPoolExecutor
import numpy as np
sys.path.insert(0, os.getcwd())
import plant.calibration.fit as _fit
from plant.calibration.fit import ModelSpec, Prepared, play_operator, presliding_state, stick_ramp  # noqa: F401


def design_full(prep: Prepared, spec: ModelSpec, q=None, dq=None, ddq=None, t=None) -> tuple[list[str], np.ndarray]:
    """Full-rate regressor columns for ``spec`` (names, array of shape (N, p))."""
    q = prep.q if q is None else q
    dq = prep.dq if dq is None else dq
    ddq = prep.ddq if ddq is None else ddq
    t = prep.t if t is None else t
    dt = prep.dt_s
    mesh = spec.backlash_width is not None and spec.presliding_k is not None
    if mesh:   # compliant mesh: gap b, wind-up displacement d = 1/presliding_k (see the module docstring)
        b, dd = spec.backlash_width, 1.0 / spec.presliding_k
        ql = play_operator(q, b + 2 * dd)
        w = np.gradient(ql, dt)
        s_rel = q - ql
        c_mesh = np.clip(np.sign(s_rel) * np.maximum(np.abs(s_rel) - 0.5 * b, 0.0) / dd, -1.0, 1.0)
    elif spec.backlash_width is not None:
        ql = play_operator(q, spec.backlash_width)
        w = np.gradient(ql, dt)
    else:
        w = dq
    names: list[str] = ["inertia"]
    cols: list[np.ndarray] = [ddq]
    if mesh:
        c = c_mesh
    elif spec.presliding_k is not None:
        c = presliding_state(w, spec.presliding_k, dt)
    else:
        use_ramp = prep.coulomb is not None and spec.backlash_width is None and dq is prep.dq
        c = prep.coulomb if use_ramp else np.sign(w)
    if spec.asymmetric:
        names += ["viscous_pos", "viscous_neg", "coulomb_pos", "coulomb_neg"]
        cols += [np.maximum(w, 0.0), np.minimum(w, 0.0), np.maximum(c, 0.0), np.minimum(c, 0.0)]
    else:
        names += ["viscous", "coulomb"]
        cols += [w, c]
    if not spec.asymmetric:
        # With direction-dependent Coulomb levels the offset is not identifiable (the velocity is
        # almost never exactly zero, so max(c,0) − min(c,0) = 1 = the offset column): it is
        # absorbed, coulomb_pos = Fc + offset, coulomb_neg = Fc − offset.
        names.append("offset")
        cols.append(np.ones_like(w))
    if spec.stribeck_vs is not None:
        names.append("stribeck")
        cols.append(c * np.exp(-((w / spec.stribeck_vs) ** 2)))
    if spec.presliding_k is not None and not mesh:
        names.append("presliding_damping")
        cols.append(w - np.abs(w) * c)
    for i, p in enumerate(spec.position_periods):
        x = 2 * np.pi * q / p
        names += [f"pos{i}_sin", f"pos{i}_cos"]
        cols += [np.sin(x), np.cos(x)]
    if spec.gravity:
        names += ["grav_sin", "grav_cos"]
        cols += [np.sin(q), np.cos(q)]
    for i, f in enumerate(spec.time_frequencies):
        x = 2 * np.pi * f * t
        names += [f"time{i}_sin", f"time{i}_cos"]
        cols += [np.sin(x), np.cos(x)]
    for nz in spec.nuisance:
        if nz == "friction_drift":
            tau = (t - t[0]) / max(float(t[-1] - t[0]), 1e-12)
            names += ["nz_drift_c1", "nz_drift_w1", "nz_drift_c2", "nz_drift_w2"]
            cols += [c * tau, w * tau, c * tau**2, w * tau**2]
        elif nz == "delay":
            names.append("nz_delay_jerk")
            cols.append(np.gradient(ddq, dt))
        elif nz == "velocity_function":
            a = np.abs(w)
            knots = np.quantile(a, [0.05, 0.25, 0.5, 0.75, 0.95])
            for j, kn in enumerate(knots):
                hinge = np.maximum(a - kn, 0.0)
                names += [f"nz_vel{j}_pos", f"nz_vel{j}_neg"]
                cols += [hinge * (w > 0), hinge * (w < 0)]
    return names, np.column_stack(cols)



if __name__ == "__main__":
    import functools
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import compliant_play_probe as play
    _fit.design_full = design_full   # before the workers fork; identical to the package's unless both slots are set
    play.main(sys.argv, functools.partial(play.one, mesh=True))
