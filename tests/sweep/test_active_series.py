"""A run's active count in bins for a sweep's bands: each row weighed by the time it covers in each bin,
so lockstep's one-second rows and the event platform's long ones give the same series."""

from __future__ import annotations

import numpy as np
import pytest

from gcs.sweep.cells import active_series


def test_one_second_rows_give_each_bin_the_mean_of_its_rows() -> None:
    rng = np.random.default_rng(3)
    time_us = np.arange(1, 2401, dtype=np.int64) * 1_000_000
    active = rng.integers(0, 13, 2400).astype(np.int32)
    series = active_series(time_us, active, 2400.0)
    assert series["bin_s"] == 10.0 and series["t_s"][:2] == [10.0, 20.0] and len(series["t_s"]) == 240
    assert series["active"] == pytest.approx(active.reshape(240, 10).mean(axis=1).round(3).tolist(), abs=1e-9)


def test_a_long_row_counts_in_every_bin_it_covers_as_its_seconds_would() -> None:
    """The same count as rows of one second, and as three rows of which one spans 25 bins and a half."""
    seconds = np.array([5] * 7 + [2] * 255 + [7] * 38, np.int32)
    per_second = active_series(np.arange(1, 301, dtype=np.int64) * 1_000_000, seconds, 300.0)
    long_rows = active_series(np.array([7, 262, 300], np.int64) * 1_000_000, np.array([5, 2, 7], np.int32), 300.0)
    assert long_rows == per_second
    assert per_second["active"][:2] == [pytest.approx(0.7 * 5 + 0.3 * 2), 2.0]
