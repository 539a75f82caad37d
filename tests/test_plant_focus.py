"""Focus plant: half-steps, LVDT, index pulses, limits (paper §3.2)."""

from __future__ import annotations

import pytest

from plant.focus import FocusPlant
from plant.params import load_parameters


@pytest.fixture
def fp():
    return FocusPlant(load_parameters().focus)


def test_halfstep_is_6_25_um(fp):
    """0.9°/half-step, 1:2 belt, 5 mm/rev screw → 6.25 µm per half-step."""
    fp.step(1)
    assert fp.position_m == pytest.approx(6.25e-6)
    fp.step(-401)
    assert fp.position_m == pytest.approx(-400 * 6.25e-6)
    assert fp.motor_encoder_counts() == -2000  # −1 motor rev of 2000 counts (assumed encoder)


def test_lvdt_spans_plus_minus_5_mm(fp):
    """LVDT: 2.5 V at centre, 0 V at −5 mm, 5 V at +5 mm."""
    assert fp.lvdt_voltage_v() == pytest.approx(2.5)
    fp.step(800)
    assert fp.lvdt_voltage_v() == pytest.approx(5.0)
    fp.step(-1600)
    assert fp.lvdt_voltage_v() == pytest.approx(0.0)


def test_four_index_pulses_over_full_travel(fp):
    """Four motor revolutions over ±5 mm give four index pulses; steps past a limit are lost."""
    fp.step(-2000)
    assert fp.position_m == pytest.approx(-5e-3) and fp.lost_halfsteps == 1200
    fp.index_pulses = 0
    fp.step(1600)
    assert fp.index_pulses == 4
    assert not fp.at_index()
    fp.reset(1.25e-3)
    assert fp.at_index()


def test_power_modes(fp):
    """Steps are accepted only with power on; hold and free keep the position."""
    fp.set_power("hold")
    fp.step(10)
    assert fp.halfsteps == 0
    fp.set_power("on")
    fp.step(10)
    assert fp.halfsteps == 10
    with pytest.raises(ValueError):
        fp.set_power("off")


def test_stall_loses_the_next_halfsteps_and_the_encoder_shows_it():
    """stall(n): the next n commanded half-steps do not move the rotor (counted in
    lost_halfsteps); the encoder counts only travelled half-steps (5 counts each)."""
    fp = FocusPlant(load_parameters().focus)
    fp.stall(3)
    for _ in range(5):
        fp.step(1)
    assert fp.halfsteps == 2 and fp.lost_halfsteps == 3 and fp.stall_halfsteps == 0
    assert fp.motor_encoder_counts() == 10
    fp.stall(2)
    fp.step(-5)
    assert fp.halfsteps == -1 and fp.lost_halfsteps == 5
    with pytest.raises(ValueError):
        fp.stall(-1)
