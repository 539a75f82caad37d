"""A backlash candidate whose declared gear spring could not be tested (issue 7, session 54).

With the drive's stiffness declared, a backlash candidate must predict held-out blocks better than the
current model with that spring in it (session 20, ``loop._beats_gear_spring``), and where the massless
play loses to it, a gap must beat the two-mass drive without one (session 38). Both need a spring with
friction through it. Where its Coulomb level does not stay positive when the model is refitted with it
(also started from the candidate's own level, session 50), there is no spring to test and the
candidate passes with no test of the spring: independent record 22019, a compliant mode without a gap
(K = 296 N·m/rad, a 7.8 Hz mode inside the fit's band), is named backlash. Refusing it there was decided
on never-used seeds and not kept (a tie: the rule acted on none of 400 two-mass records;
``data/calibration_benchmark/session54_untested_spring/``); the report now says so in the effect's
evidence, with the two-mass answer or why it could not be given (``loop._untested_spring``).

The record comes from the independent generator (``plant.calibration.bench_records``: its own
two-mass integrator, PI velocity loop and measurement chain, nothing from ``plant``).
"""
from __future__ import annotations

from plant.calibration import loop
from plant.calibration.bench_records import make_record
from plant.calibration.report import calibrate


def test_a_backlash_whose_spring_could_not_be_tested_says_so(tmp_path):
    """22019's backlash (a compliant mode, a wrong kind the loop still names) carries the caution and
    the reason the two-mass question could not be asked (the fit's inertia is 0). Main before session
    54 named it with no caution, so the check can fail."""
    rec = make_record(22019)
    assert rec.hidden == ("compliant_mode",)
    stiffness = rec.meta["two_mass"]["stiffness_nm_rad"]
    rec.write_csv(tmp_path / "r.csv")
    rep = calibrate(tmp_path / "r.csv", tmp_path / "out", plots=False, gear_stiffness=stiffness)
    (bl,) = [e for e in rep["effects"] if e["kind"] == "backlash"]
    assert "caution: " + loop.UNTESTED_SPRING in bl["evidence"]
    assert "inertia must be positive" in bl["evidence"] and "may not tell a gap" in bl["evidence"]
