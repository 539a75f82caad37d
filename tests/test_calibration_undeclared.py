"""The calibration loop on generated records with an undeclared effect (plant.calibration.generate).

Each record: the generator's rigid axis on a velocity staircase in both directions plus a
back-and-forth segment with reversals, 1 kHz, torque noise 0.05 N·m, 2^20-count encoder. The fit
is not told which effect is on. A second record (other noise seed) is the held-out record.

Stated tolerances: periods and frequencies within 2 %; periodic and imbalance amplitudes within
15 %; asymmetric friction coefficients within 10 %; backlash width within 15 %; pre-sliding
stiffness σ0 within 30 % (it is seen only through the few reversals).
"""

import pytest

from plant.calibration.fit import prepare
from plant.calibration.generate import DEFAULT_EFFECTS, generate_record
from plant.calibration.loop import run_loop


def calibrate_generated(effect: str):
    train = prepare(generate_record(effect, seed=1))
    held_out = prepare(generate_record(effect, seed=2))
    result = run_loop(train, held_out)
    return result, [e.to_spec() for e in result.effects()]


def test_clean_record_gets_no_effect():
    """A record with no unmodelled effect gets none added and no unexplained structure."""
    result, effects = calibrate_generated("none")
    assert effects == []
    assert result.unexplained == []
    p = result.final.params()
    assert p["inertia"] == pytest.approx(2.0, rel=0.03)
    assert p["viscous"] == pytest.approx(5.0, rel=0.03)
    assert p["coulomb"] == pytest.approx(3.0, rel=0.03)


@pytest.mark.parametrize(
    "kind, checks",
    [
        ("position_periodic", {"period_rad": 0.02, "amplitude_nm": 0.15}),
        ("time_periodic", {"frequency_hz": 0.02, "amplitude_nm": 0.15}),
        ("gravity_imbalance", {"amplitude_nm": 0.15}),
        ("asymmetric_friction", {"viscous_pos_nm_s_rad": 0.1, "viscous_neg_nm_s_rad": 0.1, "coulomb_pos_nm": 0.1, "coulomb_neg_nm": 0.1}),
        ("backlash", {"width_rad": 0.15}),
        ("presliding", {"sigma0_nm_rad": 0.3}),
    ],
)
def test_undeclared_effect_is_named(kind, checks):
    """The right kind is named first, with its key parameters within the stated tolerance."""
    result, effects = calibrate_generated(kind)
    assert effects, f"no effect found for {kind}: {result.log}"
    assert effects[0]["kind"] == kind, result.log
    assert len(effects) == 1, effects
    truth = DEFAULT_EFFECTS[kind]
    for name, rel in checks.items():
        assert effects[0][name] == pytest.approx(truth[name], rel=rel), (name, effects[0])
    assert result.val_rms_after < 0.5 * result.val_rms_before


def test_out_of_library_effect_is_not_forced():
    """A delay between torque and measured motion yields unexplained structure, not a confident wrong effect."""
    result, effects = calibrate_generated("delay")
    assert effects == [], effects
    assert any("delay" in u.get("note", "") for u in result.unexplained), result.unexplained


def test_generator_cli_and_csv_calibration(tmp_path):
    """generate-record writes a CSV that calibrate reads back (CLI end to end)."""
    import json

    from host.cli import main

    csv_path = tmp_path / "rec.csv"
    assert main(["generate-record", "--effect", "time_periodic", "--param", "frequency_hz=5.1", "--out", str(csv_path)]) == 0
    assert main(["calibrate", str(csv_path), "--out", str(tmp_path / "out"), "--no-plots"]) == 0
    rep = json.loads((tmp_path / "out" / "report.json").read_text())
    assert rep["effects"][0]["kind"] == "time_periodic"
    assert rep["effects"][0]["params"]["frequency_hz"] == pytest.approx(5.1, rel=0.02)


def test_generator_rejects_unknown_effect():
    """An unknown effect name raises ValueError listing the valid ones."""
    with pytest.raises(ValueError, match="valid.*presliding"):
        generate_record("cogging")
