"""Sensitivity studies through the sweep's own path: spec -> cells -> a Dask cluster -> cell files ->
results -> SALib's analysis. A test function of known indices (Ishigami, as SALib's own tests use) stands
in for the mission at the workers, so the path around it is checked against the truth; a small study of real
missions checks the rest."""

from __future__ import annotations

import io
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from rich.console import Console
from SALib.test_functions import Ishigami
from testkit import MISSIONS

from gcs.cli.main import main
from gcs.sweep.cells import Cell, make_cells
from gcs.sweep.runner import sweep
from gcs.sweep.sensitivity import analyse, indices, output_values
from gcs.sweep.spec import SpecError, load_spec

# Three real fields of pool12 (each point is checked against the scenario as a mission's would be), mapped
# onto Ishigami's [-pi, pi] by the function the workers run.
FIELDS = {"mission.theta": (10.0, 60.0), "apad.speed_mps": (0.2, 1.0), "mission.pool_threshold": (0.5, 0.9)}
ISHIGAMI_S1 = (0.3139, 0.4424, 0.0)  # a = 7, b = 0.1: the analytical indices
ISHIGAMI_ST = (0.5576, 0.4424, 0.2437)


def spec_text(method: str = "sobol", n: int = 256, extra: str = "") -> str:
    bounds = "\n".join(f"{k} = {{min = {lo}, max = {hi}}}" for k, (lo, hi) in FIELDS.items())
    return f"""
[sweep]
scenarios = ["pool12"]
strategies = ["cautious"]
seeds = [1]
platform = "event"
[sensitivity]
method = "{method}"
n = {n}
seed = 3
outputs = ["uptime_min"]
{extra}
{bounds}
"""


def ishigami_cell(cell: Cell, runs_dir: str | None) -> dict[str, Any]:
    """What a worker returns for a cell: Ishigami of its field values as the mission's minimum uptime."""
    x = [-math.pi + 2 * math.pi * (cell.values[k] - lo) / (hi - lo) for k, (lo, hi) in FIELDS.items()]
    y = float(Ishigami.evaluate(np.array([x]))[0])
    result = {"scenario": cell.scenario.name, "strategy": cell.strategy, "seed": cell.seed, "duration_s": 60.0,
              "uptime": {"avg": y, "min": y, "max": y}, "mussels": [], "days": [], "apads": []}
    return {"result": result, "series": {"bin_s": 10.0, "t_s": [], "active": []}}


def quiet() -> Console:
    return Console(file=io.StringIO(), width=200)


def test_ishigami_indices_come_back_through_the_sweep_within_salibs_intervals(tmp_path: Path) -> None:
    (tmp_path / "s.toml").write_text(spec_text(extra="second_order = false"))
    spec = load_spec(tmp_path / "s.toml")
    cells = make_cells(spec)
    assert len(cells) == 256 * (3 + 2)  # Saltelli without second order: n(D+2)
    out = tmp_path / "out"
    outcome = sweep(spec, cells, out, quiet(), workers=2, processes=False, runner=ishigami_cell)
    assert (outcome.ran, outcome.failed, outcome.rows) == (len(cells), [], len(cells))

    design, table, pairs = analyse(out)
    assert pairs.empty  # no second order asked
    assert sorted(design.names) == sorted(FIELDS)
    rows = table.set_index("field")
    for name, s1, st in zip(FIELDS, ISHIGAMI_S1, ISHIGAMI_ST, strict=True):
        r = rows.loc[name]
        assert abs(r["S1"] - s1) <= r["S1_conf"], (name, r["S1"], r["S1_conf"], s1)
        assert abs(r["ST"] - st) <= r["ST_conf"], (name, r["ST"], r["ST_conf"], st)
    # The check can fail: the same responses out of the sample's order (a pipe that lost the order) miss.
    points = [c.values for c in cells]
    x = np.array([[p[k] for k in FIELDS] for p in points])
    y = pd.read_parquet(out / "results.parquet")["uptime.min"].to_numpy()
    shuffled = indices(design, x, np.random.default_rng(1).permutation(y))[0].set_index("field")
    assert abs(shuffled.loc["apad.speed_mps", "S1"] - ISHIGAMI_S1[1]) > shuffled.loc["apad.speed_mps", "S1_conf"]


def test_the_shipped_study_in_short_form_on_the_event_platform_and_its_report(
    tmp_path: Path, capsys: pytest.CaptureFixture[str],
) -> None:
    """missions/sweeps/sensitivity.toml (docs/sensitivity.md) as the suite runs it: its fields, bounds,
    outputs and fleet, n = 2 and 3-minute missions: 2 x (2 x 8 + 2) = 36 real missions, then the report."""
    text = (MISSIONS / "sweeps/sensitivity.toml").read_text()
    text = text.replace("n = 256", "n = 2").replace('mission.duration = "6h"', 'mission.duration = "3m"')
    spec = tmp_path / "s.toml"
    spec.write_text(text.replace('"bay-capacity"', '"' + str(MISSIONS / "bay-capacity.toml") + '"'))
    out = tmp_path / "out"
    assert main(["sweep", str(spec), "--out", str(out), "--workers", "2"]) == 0
    printed = capsys.readouterr().out
    assert "sobol indices over 8 fields, 36 points (n = 2)" in printed and "apad.home_charge_w" in printed
    table = pd.read_csv(out / "report" / "sensitivity.csv")
    assert list(table.columns) == ["scenario", "strategy", "output", "field", "S1", "S1_conf", "ST", "ST_conf"]
    assert len(table) == 4 * 8 and (out / "report" / "sensitivity.png").stat().st_size > 0
    pairs = pd.read_csv(out / "report" / "sensitivity-pairs.csv")  # second order: every pair of the 8 fields
    assert list(pairs.columns) == ["scenario", "strategy", "output", "field_a", "field_b", "S2", "S2_conf"]
    assert len(pairs) == 4 * 28 and "second order: the strongest pairs" in printed
    rows = pd.read_parquet(out / "results.parquet")
    assert len(rows) == 36 and set(rows["platform"]) == {"event"} and set(rows["mussels.n"]) == {36}
    # A study with missions still to run is refused in one line: the indices need every point.
    next((out / "cells").glob("*.json")).unlink()
    assert main(["sweep", "report", str(out)]) == 2
    assert "1 of 36 points have no finished mission yet" in capsys.readouterr().err


def test_morris_through_the_same_path(tmp_path: Path) -> None:
    (tmp_path / "m.toml").write_text(spec_text("morris", 64, "levels = 4"))
    spec = load_spec(tmp_path / "m.toml")
    cells = make_cells(spec)
    assert len(spec.points) == 64 * (3 + 1) and len(cells) < len(spec.points)  # on Morris's grid points repeat
    sweep(spec, cells, tmp_path / "out", quiet(), workers=2, processes=False, runner=ishigami_cell)
    _, table, _ = analyse(tmp_path / "out")
    mu = table.set_index("field")["mu_star"]
    # Ishigami's x3 acts only with x1 (b x3^4 sin x1): its elementary effects are the smallest.
    assert mu["mission.pool_threshold"] < min(mu["mission.theta"], mu["apad.speed_mps"])
    assert (table["mu_star_conf"] > 0).all()


def test_an_integer_field_takes_each_value_as_often() -> None:
    from gcs.sweep.sensitivity_design import Design, Method

    design = Design(Method.SOBOL, ("apad.slots", "mission.theta"), ((2.0, 4.0), (10.0, 60.0)), (True, False), 256, 1,
                    second_order=False)
    counts = pd.Series([p["apad.slots"] for p in design.points()]).value_counts(normalize=True)
    assert sorted(counts.index) == [2, 3, 4] and (abs(counts - 1 / 3) < 0.03).all()


def test_a_sample_point_twice_is_one_mission(tmp_path: Path) -> None:
    # Integer bounds round: with two values only, Saltelli's points repeat, and each repeat is the same mission.
    text = spec_text(n=4).replace('mission.pool_threshold = {min = 0.5, max = 0.9}', "")
    text = text.replace("[sensitivity]", "[sensitivity]\nmission.theta = {min = 29, max = 30}")
    text = text.replace('mission.theta = {min = 10.0, max = 60.0}', "")
    (tmp_path / "s.toml").write_text(text)
    spec = load_spec(tmp_path / "s.toml")
    assert len(spec.points) == 4 * (2 * 2 + 2)
    cells = make_cells(spec)
    distinct = {(p["mission.theta"], p["apad.speed_mps"]) for p in spec.points}
    assert len(cells) == len(distinct) < len(spec.points)
    assert [c.index for c in cells] == list(range(len(cells)))


@pytest.mark.parametrize(("change", "said"), [
    (("n = 256", "n = 100"), "sensitivity.n: Sobol's sequence needs a power of 2"),
    (('method = "sobol"', 'method = "fast"'), "sensitivity.method: expected one of sobol, morris"),
    (('outputs = ["uptime_min"]', 'outputs = ["happiness"]'), "'happiness' is not an output"),
    (("max = 60.0", "max = 5.0"), "sensitivity.mission.theta: expected {min = A, max = B} with numbers A < B"),
    (("[sensitivity]", "[grid]\nmission.theta = [30]\n[sensitivity]"), "[grid]: a [sensitivity] study samples"),
    (("[sensitivity]", '[set]\n"apad.speed_mps" = 0.5\n[sensitivity]'), "apad.speed_mps: set in both"),
])
def test_a_bad_sensitivity_table_is_one_line(tmp_path: Path, change: tuple[str, str], said: str) -> None:
    (tmp_path / "s.toml").write_text(spec_text().replace(*change))
    with pytest.raises(SpecError, match=None) as caught:
        load_spec(tmp_path / "s.toml")
    assert said in str(caught.value) and "\n" not in str(caught.value)


def test_the_outputs_of_a_mission_result() -> None:
    result = {"duration_s": 43200.0, "uptime": {"avg": 90.0, "min": 60.0},
              "mussels": [{"samples_taken": 9, "samples_scheduled": 10, "dockings": [{}, {}]},
                          {"samples_taken": 1, "samples_scheduled": 10, "dockings": [{}]}],
              "days": [{"alive": 2}, {"alive": 1}], "apads": [{"drawn_wh": 100.0}, {"drawn_wh": 300.0}]}
    assert output_values(result) == {"uptime_min": 60.0, "uptime_avg": 90.0, "alive_at_end": 1.0,
                                     "apad_wh_per_day": 400.0, "samples_taken_pct": 50.0,
                                     "dockings_per_day": 6.0}


def test_a_study_on_its_first_base_samples_is_the_start_of_the_whole_one(
    tmp_path: Path, capsys: pytest.CaptureFixture[str],
) -> None:
    spec = load_spec(MISSIONS / "sweeps/sensitivity.toml")
    first = spec.first_base_samples(16)
    assert first.sensitivity is not None and first.sensitivity.n == 16
    assert len(first.points) == 16 * (2 * 8 + 2) and first.points == spec.points[:len(first.points)]
    assert {c.key for c in make_cells(first)} <= {c.key for c in make_cells(spec)}  # a later full run keeps them
    for n, said in ((48, "48 is not a power of 2 up to the spec's n = 256"), (512, "512 is not a power of 2")):
        assert main(["sweep", str(MISSIONS / "sweeps/sensitivity.toml"), "--out", str(tmp_path / "o"),
                     "--base-samples", str(n)]) == 2
        err = capsys.readouterr().err
        assert said in err and err.count("\n") == 1
    assert main(["sweep", str(MISSIONS / "sweeps/quick.toml"), "--out", str(tmp_path / "o"), "--base-samples",
                 "4"]) == 2
    assert "--base-samples: the spec has no [sensitivity] table" in capsys.readouterr().err
