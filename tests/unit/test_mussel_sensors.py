"""Simulated sensors: hydrostatic pressure and the moving anoxic patch, against closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from mussel_sim.sensors import AnoxicPatch, DummySensors, pressure_hpa


def test_pressure_is_hydrostatic() -> None:
    depth = np.array([0.0, 1.0, 10.0])
    expected = 1013.25 + 1025.0 * 9.80665 * depth / 100.0  # Pa -> hPa
    np.testing.assert_allclose(pressure_hpa(depth), expected)
    assert pressure_hpa(np.array([10.0]))[0] == pytest.approx(2018.43, abs=0.01)


def test_dummy_sensors_are_constant_with_depth_pressure() -> None:
    r = DummySensors(6.5, 17.0, 3.0).sample(np.zeros(4), np.zeros(4), np.full(4, 2.0), 123.0)
    np.testing.assert_array_equal(r.dissolved_oxygen_mg_l, np.full(4, 6.5))
    np.testing.assert_array_equal(r.temperature_degc, np.full(4, 17.0))
    np.testing.assert_array_equal(r.turbidity_ntu, np.full(4, 3.0))
    np.testing.assert_allclose(r.pressure_hpa, pressure_hpa(np.full(4, 2.0)))


def test_anoxic_patch_is_a_moving_gaussian_depression() -> None:
    patch = AnoxicPatch(
        centre_x_m=10.0, centre_y_m=-5.0, sigma_m=8.0, velocity_east_mps=0.02, velocity_north_mps=0.01,
        background_oxygen_mg_l=8.0, depression_mg_l=6.0,
    )
    t = 500.0
    cx, cy = 10.0 + 0.02 * t, -5.0 + 0.01 * t  # the centre has moved with its velocity
    x = np.array([cx, cx + 8.0, cx, cx + 1000.0])
    y = np.array([cy, cy, cy - 16.0, cy])
    r = patch.sample(x, y, np.full(4, 3.0), t)
    expected_do = 8.0 - 6.0 * np.exp(-np.array([0.0, 8.0, 16.0, 1000.0]) ** 2 / (2 * 8.0**2))
    np.testing.assert_allclose(r.dissolved_oxygen_mg_l, expected_do)
    assert r.dissolved_oxygen_mg_l[0] == pytest.approx(2.0)  # 8 - 6 at the centre
    assert r.dissolved_oxygen_mg_l[1] == pytest.approx(8.0 - 6.0 * np.exp(-0.5))  # one sigma away
    assert r.turbidity_ntu[0] == pytest.approx(2.0 + 10.0)
    np.testing.assert_allclose(r.temperature_degc, 20.0 - 0.3 * 3.0)
    np.testing.assert_allclose(r.pressure_hpa, pressure_hpa(np.full(4, 3.0)))
