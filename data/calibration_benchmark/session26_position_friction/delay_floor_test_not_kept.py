"""Session 26: the out-of-library delay description must stand for a shift the record resolves
(docs/calibration.md "Session 26").

A shift under 2 raw sample periods is refused, the floor the report already sets for a time shift
in ``unexplained``. That a real delay of several samples is still described is checked by
tests/test_calibration_undeclared.py (the project's generator) and by the blind generator's
torque-delay records in the session's bar runs (data/calibration_benchmark/session26_position_friction/).
"""

import types

import numpy as np
import pytest

from plant.calibration import loop

FS_HZ = 500.0


def _fit(shift_s, inertia=2.0):
    """The two coefficients ``_delay_s`` reads: torque = J·ddq + J·shift·jerk."""
    return types.SimpleNamespace(names=["inertia", "nz_delay_jerk"], coef=np.array([inertia, inertia * shift_s]))


@pytest.mark.parametrize("samples", [0.2, 1.0, 1.9])
def test_a_shift_under_two_samples_is_not_resolved(samples):
    dt = 1.0 / FS_HZ
    for sign in (1.0, -1.0):
        why = loop._delay_resolved(_fit(sign * samples * dt), dt)
        assert why is not None and "not resolved" in why


@pytest.mark.parametrize("samples", [2.0, 7.5])
def test_a_shift_of_two_samples_or_more_is_resolved(samples):
    dt = 1.0 / FS_HZ
    assert loop._delay_resolved(_fit(samples * dt), dt) is None
    assert loop._delay_resolved(_fit(samples * dt, inertia=0.0), dt) is None   # no inertia: shift unknown
