"""A result.json as one row whatever its fields; means with intervals; the Pareto front."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from gcs.sweep.flatten import flatten
from gcs.sweep.stats import mean_ci, pareto_front, summary


def test_fields_nobody_told_the_sweep_about_become_columns() -> None:
    result = {
        "uptime": {"avg": 70.0, "min": 50.0},
        "cost_m": 12.5,
        "end_reason": "mission time",
        "mussels": [
            {"id": 1, "uptime_pct": 50.0, "dockings": [{"t_s": 1.0}], "state_s": {"active": 10.0, "floating": 2.0},
             "first_depleted_s": None},
            {"id": 2, "uptime_pct": 90.0, "dockings": [], "state_s": {"active": 30.0, "floating": 0.0},
             "first_depleted_s": 700.0},
        ],
        "apads": [{"sysid": 1, "share": {"travelling": 0.25, "docking": 0.5}, "mussels": [1, 2]}],
        "whereabouts": [{"id": 1, "where": "seabed", "detail": "active, 0.1 m off"},
                        {"id": 2, "where": "lost", "detail": "left at the surface"}],
        "samples": [3, 1, 2],
        "empty": [],
    }
    row = flatten(result)
    assert row["uptime.avg"] == 70.0 and row["cost_m"] == 12.5 and row["end_reason"] == "mission time"
    assert row["mussels.n"] == 2
    assert (row["mussels.uptime_pct.mean"], row["mussels.uptime_pct.min"], row["mussels.uptime_pct.max"]) == (
        70.0, 50.0, 90.0)
    assert row["mussels.state_s.active.mean"] == 20.0 and row["mussels.state_s.floating.max"] == 2.0
    assert row["mussels.dockings.max"] == 1.0  # a list in a record: its length
    assert row["mussels.first_depleted_s.min"] == 700.0  # None (never depleted) is left out of the summary
    nobody = flatten({"mussels": [{"first_depleted_s": None}, {"first_depleted_s": None}]})
    assert nobody["mussels.first_depleted_s.min"] is None  # the column is there all the same
    assert row["apads.share.travelling.mean"] == 0.25 and row["apads.mussels.max"] == 2.0
    assert row["whereabouts.where=seabed"] == 1 and row["whereabouts.where=lost"] == 1
    assert not any("detail" in k for k in row)  # a sentence is not a category
    assert not any(k.endswith(("id.mean", "sysid.mean")) for k in row)  # identifiers are not figures
    assert (row["samples.n"], row["samples.mean"], row["samples.min"]) == (3, 2.0, 1.0)
    assert row["empty.n"] == 0
    assert all(not isinstance(v, list | dict) for v in row.values())


def test_mean_ci_is_students_t() -> None:
    x = np.array([1.0, 2.0, 4.0, 7.0])
    mean, half = mean_ci(x)
    lo, hi = stats.t.interval(0.95, len(x) - 1, loc=x.mean(), scale=stats.sem(x))
    assert mean == pytest.approx(3.5) and half == pytest.approx((hi - lo) / 2)
    assert np.isnan(mean_ci([5.0])[1]) and mean_ci([5.0])[0] == 5.0
    assert all(np.isnan(mean_ci([])))


def test_pareto_front_keeps_what_nothing_beats() -> None:
    # (avg, min, -cost): b beats a everywhere; c trades cost for uptime; d equals c (neither dominates).
    scores = np.array([[60, 40, -200], [65, 45, -190], [70, 50, -280], [70, 50, -280], [65, 45, -190.5]], float)
    assert pareto_front(scores).tolist() == [False, True, True, True, False]


def test_summary_marks_the_front_per_scenario() -> None:
    rows = pd.DataFrame({
        "scenario": ["s1"] * 4 + ["s2"] * 2,
        "config": ["a", "a", "b", "b", "a", "b"],
        "uptime.avg": [60, 62, 70, 72, 50, 50], "uptime.min": [40, 42, 50, 52, 30, 30],
        "uptime.max": [90] * 6, "cost_m": [100, 100, 90, 90, 10, 20], "active_avg": [8.0] * 6,
    })
    table = summary(rows, ["scenario", "config"])
    assert table[["scenario", "config", "n"]].values.tolist() == [["s1", "a", 2], ["s1", "b", 2],
                                                                  ["s2", "a", 1], ["s2", "b", 1]]
    assert table["front"].tolist() == [False, True, True, False]
    assert table["uptime.avg.mean"].tolist() == [61.0, 71.0, 50.0, 50.0]
