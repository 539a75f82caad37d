"""Session 16 prototype: the session-14 inertia rule extended to viscous friction.

A candidate whose fit drives a positive viscous coefficient of the current model (``viscous``,
or ``viscous_pos`` / ``viscous_neg`` when both models have them) to its bound 0 is refused, as
one that drives a positive inertia to 0 already is: an axis with positive viscous friction keeps
it, so a term the fit can use only by zeroing it stands in for ``Fv·dq``. Found on benchmark
seed 41 (clean sinusoid): the 4.17 N·m time line at 0.033 Hz (motion: 0.0345 Hz) comes with the
viscous coefficient 16.25 → 0 and the inertia 1.51 → 0.73.

Loaded by ``dev_runner.py`` through ``PATCH=``::

    PATCH=data/calibration_benchmark/session16_iv/viscous_rule_probe.py \
        .venv/bin/python data/calibration_benchmark/session12_constancy/dev_runner.py OUT.json [SEEDS]
"""
import plant.calibration.loop as L

_orig = L._replaces_inertia


def _replaces_physical(cur, new):
    why = _orig(cur, new)
    if why is not None:
        return why
    for name in ("viscous", "viscous_pos", "viscous_neg"):
        if name in cur.names and name in new.names:
            v0, v1 = cur.param(name), new.param(name)
            if v0 > 0 and v1 <= 0:
                return (f"takes the place of {name}: with it {name} falls from {v0:.4g} to its bound 0, so the term "
                        "stands in for the viscous friction rather than describing a torque of its own")
    return None


L._replaces_inertia = _replaces_physical
