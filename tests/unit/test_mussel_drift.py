"""Random drift (the paper's U(-0.5, 0.5) cm per axis per step) and water currents."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mussel_sim.drift import GriddedCurrent, UniformCurrent, random_drift_m
from mussel_sim.fleet import step
from mussel_sim.fleet_state import FleetInputs, FleetParams, state_from_arrays

HALF_CM = 0.5


def ks_uniform(samples: np.ndarray, lo: float, hi: float) -> float:
    """Kolmogorov-Smirnov distance between the samples' empirical CDF and U(lo, hi)."""
    x = np.sort(samples)
    n = x.size
    cdf = (x - lo) / (hi - lo)
    return float(max((np.arange(1, n + 1) / n - cdf).max(), (cdf - np.arange(n) / n).max()))


def check_uniform_half_cm(d_cm: np.ndarray) -> None:
    n = d_cm.size
    assert d_cm.min() >= -HALF_CM and d_cm.max() < HALF_CM
    var = 1 / 12  # of U(-0.5, 0.5), cm^2
    assert abs(d_cm.mean()) < 5 * np.sqrt(var / n)
    # sd of the sample variance of a uniform: sqrt((mu4 - sigma^4) / n), mu4 = 1/80
    assert abs(d_cm.var() - var) < 5 * np.sqrt((1 / 80 - var**2) / n)
    assert ks_uniform(d_cm, -HALF_CM, HALF_CM) < 1.95 / np.sqrt(n)  # alpha = 0.001


def test_drift_draws_are_uniform_half_centimetre() -> None:
    d = random_drift_m(np.random.default_rng(2024), 100_000)
    assert d.shape == (2, 100_000)
    for axis in d:
        check_uniform_half_cm(axis * 100)
    # East and north are independent draws.
    assert abs(np.corrcoef(d)[0, 1]) < 5 / np.sqrt(100_000)


def test_fleet_positions_drift_by_the_paper_distribution_each_step() -> None:
    p = FleetParams()
    n = 2000
    s = state_from_arrays(np.arange(1, n + 1), np.zeros(n), np.zeros(n), np.ones(n), p)
    rng = np.random.default_rng(7)
    dx, dy = [], []
    for _ in range(25):
        s2, _ = step(s, FleetInputs(), p, rng, 1.0)
        dx.append(s2.x_m - s.x_m)
        dy.append(s2.y_m - s.y_m)
        s = s2
    check_uniform_half_cm(np.concatenate(dx) * 100)
    check_uniform_half_cm(np.concatenate(dy) * 100)


def test_uniform_current_moves_free_mussels_not_docked_ones() -> None:
    p = FleetParams(drift_half_width_m=0.0, current=UniformCurrent(0.1, -0.05))
    s = state_from_arrays([1, 2], [0.0, 5.0], [0.0, 5.0], [1.0, 1.0], p)
    s, _ = step(s, FleetInputs.make(dock=[(2, 1, 1)]), p, np.random.default_rng(0), 1.0)
    rng = np.random.default_rng(0)
    for _ in range(9):
        s, _ = step(s, FleetInputs(), p, rng, 1.0)
    assert s.x_m[0] == pytest.approx(10 * 0.1, abs=1e-12)  # current * dt_s, 10 steps of 1 s
    assert s.y_m[0] == pytest.approx(10 * -0.05, abs=1e-12)
    assert (s.x_m[1], s.y_m[1]) == (5.0, 5.0)  # docked: held by the aPad, not the water


def bilinear(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A field that bilinear interpolation must reproduce exactly."""
    return 0.1 + 0.002 * x - 0.003 * y + 1e-4 * x * y, -0.2 + 0.001 * x + 0.004 * y - 2e-5 * x * y


def grid() -> GriddedCurrent:
    xs = -50.0 + 10.0 * np.arange(11)
    ys = -20.0 + 5.0 * np.arange(9)
    gx, gy = np.meshgrid(xs, ys)  # (ny, nx)
    east, north = bilinear(gx, gy)
    return GriddedCurrent(-50.0, -20.0, 10.0, 5.0, east, north)


def test_gridded_current_interpolates_bilinearly() -> None:
    rng = np.random.default_rng(1)
    x = rng.uniform(-50, 50, 500)
    y = rng.uniform(-20, 20, 500)
    ve, vn = grid().velocity_mps(x, y, 0.0)
    ee, en = bilinear(x, y)
    np.testing.assert_allclose(ve, ee, atol=1e-12)
    np.testing.assert_allclose(vn, en, atol=1e-12)


def test_gridded_current_holds_the_edge_value_outside() -> None:
    ve, vn = grid().velocity_mps(np.array([80.0, -90.0]), np.array([3.0, -70.0]), 0.0)
    ee, en = bilinear(np.array([50.0, -50.0]), np.array([3.0, -20.0]))
    np.testing.assert_allclose(ve, ee, atol=1e-12)
    np.testing.assert_allclose(vn, en, atol=1e-12)


def test_gridded_current_drives_the_fleet_and_round_trips(tmp_path: Path) -> None:
    g = grid()
    g.save_npz(tmp_path / "current.npz")
    back = GriddedCurrent.from_npz(tmp_path / "current.npz")
    p = FleetParams(drift_half_width_m=0.0, current=back)
    s = state_from_arrays([1], [12.0], [-3.0], [1.0], p)
    s, _ = step(s, FleetInputs(), p, np.random.default_rng(0), 2.0)
    ee, en = bilinear(np.array([12.0]), np.array([-3.0]))
    assert s.x_m[0] == pytest.approx(12.0 + 2.0 * ee[0], abs=1e-12)
    assert s.y_m[0] == pytest.approx(-3.0 + 2.0 * en[0], abs=1e-12)


def test_gridded_current_rejects_bad_grids() -> None:
    with pytest.raises(ValueError):
        GriddedCurrent(0.0, 0.0, 1.0, 1.0, np.zeros((1, 3)), np.zeros((1, 3)))
    with pytest.raises(ValueError):
        GriddedCurrent(0.0, 0.0, 0.0, 1.0, np.zeros((2, 2)), np.zeros((2, 2)))
