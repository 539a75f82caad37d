"""Session 14 prototype, not kept: corrected least squares for the encoder's quantisation noise.

Patches ``plant.calibration.fit._solve`` so the linear parameters solve ``XᵀX − m·Σ`` instead of
``XᵀX`` (``Σ`` diagonal: the variance of the quantisation noise in the decimated derivative
columns, simulated through the record's own filter/differentiation/decimation chain, seed 0).
Active only with ``CLS=1``; ``OWNMOTION=1`` simulates the noise by re-quantising the record's own
filtered motion (else a white uniform error of one count). This file is the last variant (the
inertia column only); the first run also corrected ``viscous`` and ``nz_delay_jerk`` (the tuple in
``_solve``). Run from the repository root::

    CLS=1 OWNMOTION=1 PATCH=data/calibration_benchmark/session14_inertia/cls_not_kept.py \
        .venv/bin/python data/calibration_benchmark/session12_constancy/dev_runner.py OUT.json
"""
import os
import numpy as np
from scipy import optimize, signal
import plant.calibration.fit as F
import plant.calibration.loop as L

NV = {}
def noise_var(prep):
    key = id(prep)
    if key in NV: return NV[key]
    rng = np.random.default_rng(0)
    res = prep.position_resolution
    n = prep.t.size + F.N_BORDER
    fs = 1 / prep.dt_s
    if os.environ.get("OWNMOTION"):
        x = prep.q
        e = np.floor(x / res + rng.uniform(0.0, 1.0)) * res - x
        e -= e.mean()
        sl = slice(0, None)
    else:
        e = rng.uniform(-0.5 * res, 0.5 * res, n)
        sl = slice(F.N_BORDER, None)
    b, a = signal.butter(4, prep.cutoff_hz / (fs / 2))
    ef = signal.filtfilt(b, a, e, padtype="odd", padlen=3 * (max(len(a), len(b)) - 1))
    d1 = np.gradient(ef, prep.dt_s); d2 = np.gradient(d1, prep.dt_s); d3 = np.gradient(d2, prep.dt_s)
    D = prep.dec(np.column_stack([d1[sl], d2[sl], d3[sl]]))
    v = {"viscous": float(np.var(D[:, 0])), "inertia": float(np.var(D[:, 1])), "nz_delay_jerk": float(np.var(D[:, 2]))}
    NV[key] = v
    return v

CUR = [None]
_orig_solve = F._solve
def _solve(X, y, names=None):
    prep = CUR[0]
    if prep is None or names is None or not os.environ.get("CLS"):
        return _orig_solve(X, y, names)
    nv = noise_var(prep)
    m = X.shape[0]
    S = np.array([nv.get(n, 0.0) if n in ("inertia",) else 0.0 for n in names])
    A = X.T @ X - m * np.diag(S)
    bvec = X.T @ y
    try:
        Lc = np.linalg.cholesky(A)
    except np.linalg.LinAlgError:
        return _orig_solve(X, y, names)
    M = Lc.T; r = np.linalg.solve(Lc, bvec)
    coef = np.linalg.solve(M, r)
    lo = np.array([0.0 if n in F.NONNEGATIVE else -np.inf for n in names])
    if np.any(coef < lo):
        coef = optimize.lsq_linear(M, r, bounds=(lo, np.full(len(names), np.inf)), method="bvls").x
    return coef, y - X @ coef
F._solve = _solve; L._solve = _solve

_prep_orig = F.prepare
def _prepare(record, *a, **k):
    p = _prep_orig(record, *a, **k)
    if record.extra.get("format") != "emps":
        CUR[0] = p
    else:
        CUR[0] = None
    return p
F.prepare = _prepare
import plant.calibration.report as R
R.prepare = _prepare
