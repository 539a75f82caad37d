"""Encoders and shunt: quantization, wrap, resolution (paper §2.2, §3.2, §3.3)."""

from __future__ import annotations

import math

import pytest

from plant.axis import ARCSEC_PER_RAD, AxisPlant
from plant.params import load_parameters


@pytest.fixture
def ax():
    return AxisPlant(load_parameters().ra)


def test_incremental_resolution_matches_paper(ax):
    """One incremental count is 0.01148″, the paper's '0.011 arc sec' (§3.2)."""
    res = ax.params.encoders.arcsec_per_count
    assert res == pytest.approx(1_296_000 / (4_608_000 * 24.5))
    assert round(res, 3) == 0.011


def test_incremental_count_is_floor(ax):
    """count = floor(θ·24.5/2π·4 608 000), signed and cumulative."""
    per_count_rad = 2 * math.pi / (24.5 * 4_608_000)
    for n in (0, 1, 7, -1, -8, 123_456_789, -98_765_432):
        ax.axis_angle_rad = (n + 0.5) * per_count_rad  # mid-count: immune to last-bit rounding
        assert ax.qei_counts() == n
        ax.axis_angle_rad = (n + 0.999) * per_count_rad
        assert ax.qei_counts() == n
    ax.axis_angle_rad = 0.02 / ARCSEC_PER_RAD
    assert ax.qei_counts() == 1
    ax.axis_angle_rad = -0.001 / ARCSEC_PER_RAD
    assert ax.qei_counts() == -1


def test_absolute_29_bit_wraps(ax):
    """Absolute word = floor(θ mod 2π / 2π · 2**29), 0 .. 2**29-1, wrapping each revolution."""
    ax.axis_angle_rad = 0.0
    assert ax.absolute_counts() == 0
    ax.axis_angle_rad = math.pi
    assert ax.absolute_counts() == 2 ** 28
    ax.axis_angle_rad = -1e-9
    assert ax.absolute_counts() == 2 ** 29 - 1
    ax.axis_angle_rad = 2 * math.pi + 1e-3
    assert ax.absolute_counts() == math.floor(1e-3 / (2 * math.pi) * 2 ** 29)
    assert 1_296_000 / 2 ** 29 == pytest.approx(0.002414, rel=1e-3)  # 0.0024″ per absolute count


def test_shunt_voltage_is_point_one_ohm_times_current(ax):
    """Shunt voltage = 0.1 Ω × armature current, per motor."""
    ax.set_duties(0.3, 0.075)
    ax.advance_to(20_000)
    ia, ib = ax.motor_current_a
    assert ia > 0 and ib > 0
    assert ax.shunt_voltage_v("a") == pytest.approx(0.1 * ia)
    assert ax.shunt_voltage_v("b") == pytest.approx(0.1 * ib)
    with pytest.raises(ValueError):
        ax.shunt_voltage_v("c")


def test_incremental_error_parameter():
    """The optional once-per-encoder-revolution error shifts counts; perfect removes it."""
    p = load_parameters(overrides={"axes.ra.encoders.incremental_error_arcsec": 0.05})
    ax = AxisPlant(p.ra)
    per_count_rad = 2 * math.pi / (24.5 * 4_608_000)
    base = 1_152_000  # encoder shaft at 90° (+0.3 count): error = +0.05″ = +4.36 counts
    ax.axis_angle_rad = (base + 0.3) * per_count_rad
    assert ax.qei_counts() - base in (4, 5)
    perfect = AxisPlant(load_parameters(overrides={"axes.ra.encoders.incremental_error_arcsec": 0.05,
                                                   "perfect": True}).ra)
    perfect.axis_angle_rad = ax.axis_angle_rad
    assert perfect.qei_counts() == base
