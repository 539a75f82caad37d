"""One source per fact: what the host commands and reports follows what the boards and plant ran.

Each test reproduces one of the three wrong results of issue 8 (each failed before the board
registry / session refactor, and passes after).
"""

import re
from pathlib import Path

import pytest
import yaml

from host.runner import run_scenario
from host.scenario import parse_scenario

from plant.params import load_parameters

ROOT = Path(__file__).resolve().parent.parent

OPEN_LOOP = """\
name: ol
seed: 1
plant: {{preload: low}}
controller: {{ra: {ra}}}
segments:
  - {{name: ol, axis: ra, mode: open_loop, rate_arcsec_s: 1000, duration_s: 0.3}}
"""


def _open_loop_duty_q15(tmp_path: Path, ra: str) -> int:
    out = tmp_path / ra.replace(" ", "").replace(":", "-").strip("{}")
    run_scenario(parse_scenario(OPEN_LOOP.format(ra=ra), str(tmp_path / "s.yaml")), out, plots=False)
    (value,) = re.findall(r"OPEN_LOOP\s.*value=(\d+)", (out / "commands.log").read_text())
    return int(value)


def test_open_loop_duty_map_uses_the_counter_fraction_the_firmware_runs(tmp_path):
    """A scenario's counter fraction p reaches the host's open-loop duty map: the net drive of the
    twin motors is (1 − p)·d·V (paper §3.3, superposition), so the duty holding a given speed
    must scale as 1/(1 − p) — d(p = 0.10)·0.90 = d(p_file)·(1 − p_file) up to Q15 rounding."""
    p_file = load_parameters().axes["ra"].drive.counter_fraction
    assert p_file != 0.10
    d_file = _open_loop_duty_q15(tmp_path, "{}")                      # the file's p
    d_010 = _open_loop_duty_q15(tmp_path, "{counter_fraction: 0.10}")
    assert d_010 * 0.90 == pytest.approx(d_file * (1.0 - p_file), abs=2.0)
    assert d_010 < d_file


def test_report_shows_the_friction_the_plant_integrates(tmp_path):
    """With a ``presliding`` effect the plant integrates the effect's σ0/σ1; the report says so
    (it used to print the parameter file's σ0 = 1e8)."""
    tree = yaml.safe_load((ROOT / "plant/parameters.yaml").read_text(encoding="utf-8"))
    tree["axes"]["ra"]["effects"] = [{"kind": "presliding", "sigma0_nm_rad": 3.0e7, "sigma1_nm_s_rad": 2.0e5}]
    (tmp_path / "p.yaml").write_text(yaml.safe_dump(tree), encoding="utf-8")
    sc = parse_scenario("name: pre\nplant: {parameter_file: p.yaml, preload: low}\n"
                        "segments:\n  - {name: s, mode: stop, duration_s: 0.2}\n", str(tmp_path / "s.yaml"))
    rep = run_scenario(sc, None).report
    assert rep["plant"]["ra"]["sigma0_nm_rad"] == 3.0e7
    assert rep["plant"]["ra"]["sigma1_nm_s_rad"] == 2.0e5
    assert rep["plant"]["ra"]["effects"] == ["presliding"]
    assert rep["plant"]["dec"]["sigma0_nm_rad"] == tree["axes"]["dec"]["friction"]["sigma0_nm_rad"]["value"]


def test_report_scales_counts_with_the_encoder_the_boards_run(tmp_path):
    """With another encoder in the parameter file (roller 1:49 instead of 1:24.5) the firmware
    tracks at 15″/s with its own counts, and the host's report measures 15″/s too, in agreement
    with the plant's true angle (it used to fix 4.608e6 × 24.5 counts/rev and report 30″/s)."""
    sc = parse_scenario(
        "name: enc\nplant:\n  preload: low\n  overrides: {axes.ra.encoders.roller_ratio: 49.0, "
        "axes.dec.encoders.roller_ratio: 49.0}\n"
        "segments:\n  - {name: track, axis: ra, mode: track, duration_s: 6, settle_s: 3}\n", str(tmp_path / "s.yaml"))
    (seg,) = run_scenario(sc, None).report["segments"]
    assert seg["mean_rate_arcsec_s"] == pytest.approx(15.0, abs=0.3)
    assert seg["resolution_pct"] == pytest.approx(1_296_000 / (4_608_000 * 49.0) / 0.1 / 15.0 * 100, rel=1e-3)
    assert abs(seg["peak_error_pct"] - seg["truth"]["peak_error_pct"]) < 2 * seg["resolution_pct"] + 1.0


def test_client_node_table_is_the_protocols_node_of():
    """The host client's per-identifier node table (a list, read per frame) gives
    ``bus.protocol.node_of`` for every 11-bit identifier: one source, the COB table."""
    from bus import protocol as P
    from host import client as C
    assert [C._node_of(c) for c in range(0x800)] == [P.node_of(c) for c in range(0x800)]
