"""The firmware's safety limits (boards/safety.py) can be overridden from a scenario, are checked
when it loads, reach the boards that were built, and the report reads them from those boards."""

import pytest

from boards.safety import DEFAULT_SAFETY
from bus.errors import ConfigurationError
from host.network import build_network
from host.scenario import parse_scenario

BASE = """\
name: safety-override
{safety}
segments:
  - {{name: s, axis: ra, mode: stop, duration_s: 1}}
"""


def test_overrides_reach_the_axis_and_reader_boards_and_the_report():
    sc = parse_scenario(BASE.format(safety="safety: {host_watchdog_us: 5000000, brake_decel_arcsec_s2: 9000}"),
                        "s.yaml")
    tel = build_network(sc)
    try:
        for name in ("ra-axis", "dec-axis", "ra-reader", "dec-reader"):
            sf = tel.boards[name].safety
            assert sf.host_watchdog_us == 5_000_000 and sf.brake_decel_arcsec_s2 == 9000.0
            assert sf.reader_timeout_us == DEFAULT_SAFETY.reader_timeout_us     # the rest unchanged
        summary = tel.controller_summary()
        assert summary["ra"]["safety"]["host_watchdog_us"] == 5_000_000
        # the reader's braking zone follows the overridden deceleration
        assert tel.boards["ra-reader"].safety.braking_distance_arcsec(10_800) > \
            DEFAULT_SAFETY.braking_distance_arcsec(10_800)
    finally:
        tel.close()


def test_host_watchdog_can_be_disabled_with_null():
    sc = parse_scenario(BASE.format(safety="safety: {host_watchdog_us: null}"), "s.yaml")
    assert sc.safety_limits().host_watchdog_us is None


@pytest.mark.parametrize("body, words", [
    ("safety: {host_watchdog: 5}", ["s.yaml", "unknown safety key 'host_watchdog'", "host_watchdog_us"]),
    ("safety: {brake_decel_arcsec_s2: .inf}", ["s.yaml", "brake_decel_arcsec_s2"]),
    ("safety: {reader_timeout_us: 0}", ["s.yaml", "reader_timeout_us must be > 0"]),
    ("safety: {reader_timeout_us: 1.5}", ["s.yaml", "reader_timeout_us", "integer"]),
    ("safety: {gain_band: null}", ["s.yaml", "gain_band", "null"]),
])
def test_bad_overrides_are_one_line_errors_naming_file_and_key(body, words):
    with pytest.raises(ConfigurationError) as e:
        parse_scenario(BASE.format(safety=body), "s.yaml")
    msg = str(e.value)
    assert len(msg.splitlines()) == 1 and all(w in msg for w in words), msg
