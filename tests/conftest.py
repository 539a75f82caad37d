"""Test-suite settings.

Hypothesis: no per-example deadline. The machines this suite runs on are shared and noisy (2
cores, other jobs), so a wall-clock deadline turns load into failures; speed is measured by the
benchmark commands (`schmidt-fil bench`, `benchmark-calibration`), never by a timed test.
"""

from hypothesis import HealthCheck, settings

settings.register_profile("schmidt-fil", deadline=None,
                          suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("schmidt-fil")
