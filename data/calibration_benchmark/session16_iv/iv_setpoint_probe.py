"""Session 16 prototype: IDIM-IV with the velocity set-point as the instrument of the inertia.

The logged torque of a velocity loop carries the loop's reaction to the encoder's quantisation
(``kp·`` the velocity noise), which is correlated with the noise in the measured acceleration:
least squares then biases the inertia low and smooth columns (a time line, gravity) stand in for
part of ``J·ddq`` (session 14). An instrument that is correlated with the true acceleration and
not with that noise removes the bias: the set-point's derivative, which a drive log usually
carries and the controller knows exactly (closed-loop identification, Janot, Vandanjon & Gautier,
IEEE TCST 2014). Here the generator's ``v_ref`` (captured from ``bench_records._simulate``, logged
at the record's rate) stands in for a set-point column of the log.

Loaded by ``dev_runner.py`` through ``PATCH=`` (uses ``iv_probe.py``'s two-stage solve; ``IV=ref``).
"""
import importlib.util
import os
import pathlib

import numpy as np

import plant.calibration.bench_records as B
import plant.calibration.fit as F

os.environ["IV"] = "ref"
_spec = importlib.util.spec_from_file_location("iv_probe", pathlib.Path(__file__).with_name("iv_probe.py"))
_mod = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_mod)

CAP: dict = {}
_sim = B._simulate


def _capture(v_ref, ctrl_dt, n_sub, log_every, p):
    CAP["v_ref"] = np.array(v_ref)
    CAP["log_every"] = int(log_every)
    return _sim(v_ref, ctrl_dt, n_sub, log_every, p)


B._simulate = _capture


def setpoint_acceleration(prep):
    if "v_ref" not in CAP or prep.record.extra.get("format") == "emps":
        return None
    v = CAP["v_ref"][:: CAP["log_every"]]
    n = prep.record.position.size
    if v.size < n or prep.record.extra.get("pre_decimation"):
        return None
    a = np.gradient(v[:n], prep.dt_s)
    return a[F.N_BORDER:]


_mod.iv_acceleration = setpoint_acceleration
