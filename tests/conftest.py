"""Test-suite settings.

Hypothesis: no per-example deadline. The machines this suite runs on are shared and noisy (2
cores, other jobs), so a wall-clock deadline turns load into failures; speed is measured by the
benchmark commands (`schmidt-fil bench`, `benchmark-calibration`), never by a timed test.

The vcan guest (tests/test_vcan_guest.py): its QEMU run starts as soon as the session's tests are
collected, so that it runs on one core beside the rest of the suite on the other, and its test
waits for it (session 55: one after the other, CI came within a minute of its 45-minute limit).
A session that ends before the test stops the guest.
"""

import os

# BLAS single-threaded, set before anything imports numpy (nothing has when pytest loads this file):
# the vcan guest's QEMU keeps one of the two cores busy from the start of the session (below), and
# OpenBLAS's two threads on the one core left spin against each other. Measured in CI (session 55):
# tests of 26–31 s took 4–9 min each while the guest ran. The suite passed both ways (CI ran two
# threads until session 55, local runs one); a value the user set is kept. Subprocesses (the CLI,
# the benchmark's workers) inherit it.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from hypothesis import HealthCheck, settings  # noqa: E402

settings.register_profile("schmidt-fil", deadline=None,
                          suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("schmidt-fil")


def pytest_collection_finish(session):
    if session.config.option.collectonly:
        return
    import test_vcan_guest   # tests/ is on sys.path (rootdir conftest); imported here, not collected twice

    run = test_vcan_guest.start_if_collected(session.items)
    if run is not None:
        test_vcan_guest.GUEST_RUN.update(run=run, session=session)


def pytest_sessionfinish(session, exitstatus):
    import test_vcan_guest

    # only the session that started the guest: `schmidt-fil conform` runs its suite with pytest.main
    # inside the tests of test_conformance*.py, and those nested sessions call this hook too (found in
    # CI, session 55: the first nested session dropped the guest run, and the test booted a second)
    if test_vcan_guest.GUEST_RUN.get("session") is not session:
        return
    run = test_vcan_guest.GUEST_RUN.pop("run", None)
    test_vcan_guest.GUEST_RUN.pop("session", None)
    if run is not None:
        run.stop()
