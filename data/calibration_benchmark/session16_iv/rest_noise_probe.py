"""Session 16 prototype: the Coulomb column ramps only where the velocity is at the encoder's noise
level, not wherever it is below 2 % of the 95th-percentile speed.

Session 13's ramp (``fit.stick_ramp``) replaces ``sign(dq)`` by a straight line across every run
of full-rate samples with ``|dq| < 2 %`` of the 95th-percentile speed. On a sinusoid that run
lasts ``0.04/ω`` (0.19 s on seed 41, whose axis never dwells): the modelled friction then flips
over 0.19 s while the real one flips in milliseconds, and the difference — a pulse at each
reversal whose sign follows the direction of the flip — is what a time line at the motion
frequency, gravity and a delay stand in for. Here the ramp's rest mask is ``|dq| < 3·σ_v``, with
``σ_v`` the standard deviation of the velocity noise one count of white quantisation error makes
through the record's own filter and differentiation (simulated, seed 0). The decimated samples
dropped from the fit are unchanged (2 % rule).

Loaded by ``dev_runner.py`` through ``PATCH=``.
"""
import numpy as np
from scipy import signal

import plant.calibration.fit as F
import plant.calibration.loop as L
import plant.calibration.report as R

_orig_prepare = F.prepare


def velocity_noise_std(prep) -> float:
    rng = np.random.default_rng(0)
    fs = 1.0 / prep.dt_s
    n = min(prep.t.size + F.N_BORDER, 200_000)
    e = rng.uniform(-0.5, 0.5, n) * prep.position_resolution
    b, a = signal.butter(4, prep.cutoff_hz / (fs / 2))
    ef = signal.filtfilt(b, a, e, padtype="odd", padlen=3 * (max(len(a), len(b)) - 1))
    return float(np.std(np.gradient(ef, prep.dt_s)[F.N_BORDER:-F.N_BORDER]))


def prepare(record, *a, **k):
    p = _orig_prepare(record, *a, **k)
    if p.coulomb is not None and p.position_resolution > 0:
        sv = velocity_noise_std(p)
        p.coulomb = F.stick_ramp(np.sign(p.dq), np.abs(p.dq) < 3.0 * sv)
        p.__dict__["rest_velocity"] = 3.0 * sv
    return p


F.prepare = prepare
R.prepare = prepare
if hasattr(L, "prepare"):
    L.prepare = prepare
