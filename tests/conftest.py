"""Test-suite settings.

Hypothesis: no per-example deadline. The machines this suite runs on are shared and noisy (2
cores, other jobs), so a wall-clock deadline turns load into failures; speed is measured by the
benchmark commands (`schmidt-fil bench`, `benchmark-calibration`), never by a timed test.

The vcan guest (tests/test_vcan_guest.py): its QEMU run starts as soon as the session's tests are
collected, so that it runs on one core beside the rest of the suite on the other, and its test
waits for it (session 55: one after the other, CI came within a minute of its 45-minute limit).
A session that ends before the test stops the guest.
"""

from hypothesis import HealthCheck, settings

settings.register_profile("schmidt-fil", deadline=None,
                          suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("schmidt-fil")


def pytest_collection_finish(session):
    if session.config.option.collectonly:
        return
    import test_vcan_guest   # tests/ is on sys.path (rootdir conftest); imported here, not collected twice

    run = test_vcan_guest.start_if_collected(session.items)
    if run is not None:
        test_vcan_guest.GUEST_RUN["run"] = run


def pytest_sessionfinish(session, exitstatus):
    import test_vcan_guest

    run = test_vcan_guest.GUEST_RUN.pop("run", None)
    if run is not None:
        run.stop()
