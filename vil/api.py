"""The calls of the `vil` package: each the same mission, folder and checks as its command."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import Any

import pandas as pd
from rich.console import Console

from gcs.mission.headless import run_mission, run_stem
from gcs.records.run_folder import RunFolder
from gcs.scenario.model_params import check_inputs
from gcs.scenario.reader import (
    Scenario,
    ScenarioError,
    load_scenario,
    read_toml,
    resolve_scenario,
    scenario_from_data,
)
from gcs.strategies import StrategyError, load_strategy
from gcs.sweep.cells import make_cells, patched
from gcs.sweep.cluster import ClusterError
from gcs.sweep.runner import sweep as run_sweep
from gcs.sweep.spec import SpecError, load_spec
from missiontime.durations import parse_duration_s
from vil.main_guard import ADVICE, unguarded_call
from vil.result import Result

RUNS = Path("runs")  # where `vil run` puts its folders too


class Error(ValueError):
    """Input the mission cannot run with (one line: what and where)."""


def scenario(name: str | Path = "pool12", fields: dict[str, Any] | None = None) -> Scenario:
    """A scenario by file or shipped name, with `fields` ("table.field": value, as a sweep's) changed.
    The variant is checked as a file would be: a wrong field or value is an `Error` naming it."""
    try:
        path = resolve_scenario(name)
        return scenario_from_data(path, patched(read_toml(path), fields)) if fields else load_scenario(path)
    except ScenarioError as exc:
        raise Error(str(exc)) from None


def run(
    of: str | Path | Scenario = "pool12", *, strategy: str | None = None, seed: int | None = None,
    duration: str | float | None = None, theta: float | None = None, draw_fleet: bool = False,
    out: str | Path = RUNS,
) -> Result:
    """One mission in lockstep, as `vil run` runs it (same scenario, strategy and seed: same figures),
    in a new folder `out/SCENARIO-STRATEGY-seedN-runK`. `duration`: seconds or "40m", "24h", "7d"."""
    base = of if isinstance(of, Scenario) else scenario(of)
    try:
        name = None if strategy is None else load_strategy(strategy)
        duration_s = None if duration is None else parse_duration_s(duration)
        s = base.with_overrides(strategy=name, seed=seed, duration_s=duration_s, theta=theta)
        if draw_fleet:  # the seed's own fleet, not the scenario's saved start (`vil run --draw-fleet`)
            s = replace(s, fleet=replace(s.fleet, start_config=None))
        check_inputs(s)
    except (ScenarioError, StrategyError, ValueError) as exc:
        raise Error(str(exc)) from None
    folder = RunFolder.new(Path(out), run_stem(s))
    args = {k: v for k, v in dict(strategy=strategy, seed=seed, duration=duration, theta=theta,
                                  draw_fleet=draw_fleet or None).items() if v is not None}
    folder.command.write_text(f"vil.run({json.dumps(str(s.path))}, **{args!r})\n", encoding="utf-8")
    folder.point_latest()
    run_mission(s, folder.path)
    return Result.read(folder)


def load(run_folder: str | Path) -> Result:
    """A recorded run (a folder `vil run`, `vil.run` or the console wrote; `runs/latest` too)."""
    folder = RunFolder.at(run_folder)
    if not folder.result.is_file():
        raise Error(f"{folder.path}: no {folder.result.name} (a run still going, or not a run folder)")
    return Result.read(folder)


def sweep(spec: str | Path, out: str | Path, *, scheduler: str | None = None, workers: int | None = None,
          quiet: bool = True) -> pd.DataFrame:
    """The missions of a sweep spec on Dask (a local cluster, or `scheduler`'s), those already in
    `out` kept; one row per mission, as `out/results.parquet` (docs/sweeps.md).

    A local cluster's workers are spawned processes that import the calling script again, so in a
    script call it under `if __name__ == "__main__":` (a notebook needs nothing); unguarded, it is
    an `Error` saying so before any process starts."""
    unguarded = unguarded_call() if scheduler is None else None
    if unguarded is not None:
        raise Error(ADVICE.format(file=unguarded[0], line=unguarded[1]))
    try:
        loaded = load_spec(spec)
        cells = make_cells(loaded)
        outcome = run_sweep(loaded, cells, Path(out), Console(quiet=quiet), scheduler, workers)
    except (SpecError, ClusterError) as exc:
        raise Error(str(exc)) from None
    if outcome.failed:
        raise Error(f"{len(outcome.failed)} of {outcome.cells} missions failed: {outcome.failed[0].why} "
                    f"(tracebacks in {Path(out) / 'failed.txt'})")
    return pd.read_parquet(Path(out) / "results.parquet")
