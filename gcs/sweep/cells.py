"""The missions of a sweep: one cell per (scenario, point, strategy, seed), every one checked before
any runs, and what a worker does with one.

A cell's key is a hash of its inputs (the scenario's fields after the sweep's changes, the
strategy, the seed, how the fleet is drawn), so a finished cell is found again by any later run
of a spec that asks for the same mission, and a changed field is a new cell. The key does not
cover the code: after changing a strategy, sweep into a new folder.
"""

from __future__ import annotations

import copy
import hashlib
import json
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from gcs.mission.headless import run_mission, run_stem
from gcs.mission.platform import DEFAULT_PLATFORM, Platform
from gcs.mission.start import RunOptions, check_start, check_strategy, variant
from gcs.mission.world import World
from gcs.scenario.reader import Scenario, ScenarioError, load_scenario, scenario_from_data
from gcs.strategies import StrategyError, fingerprint, load_strategy, shipped_names, source_of
from gcs.sweep.spec import SweepSpec, Value
from missiontime import US_PER_S

SERIES_POINTS = 240  # at most this many points of a run's active count are kept (10 s bins on 40 min)
SERIES_MIN_BIN_S = 10.0


@dataclass(frozen=True)
class Cell:
    index: int  # place in the spec's order (scenario, point, strategy, seed): rows are sorted by it
    key: str  # hash of the inputs: the cell's file in DIR/cells
    scenario: Scenario  # with the sweep's fields, strategy and seed applied
    values: dict[str, Value]  # the swept fields' values
    strategy: str
    seed: int
    strategy_source: str = ""  # what loads a strategy from outside the package on a worker (`load_strategy`)
    platform: Platform = DEFAULT_PLATFORM

    @property
    def label(self) -> str:
        values = " ".join(f"{k}={v}" for k, v in self.values.items())
        return f"{self.scenario.name} {self.strategy} seed {self.seed}" + (f" {values}" if values else "")


def make_cells(spec: SweepSpec) -> list[Cell]:
    """Every mission of the spec, each scenario checked with each point's fields (`SpecError` if one fails).
    A strategy from a file is found from the spec's folder."""
    try:
        strategies = (shipped_names() if spec.strategies is None
                      else tuple(load_strategy(s, spec.path.parent) for s in spec.strategies))
    except StrategyError as exc:
        raise spec.fail(f"sweep.strategies: {exc}") from None
    cells: list[Cell] = []
    for ref in spec.scenarios:
        path, raw = _scenario_toml(spec, ref)
        for point in spec.points:
            fields = spec.fixed | point
            data = patched(raw, fields)
            fleet = RunOptions(draw_fleet=spec.draw_fleet)
            try:
                base = scenario_from_data(path, data)
                check_start(base, fleet)
                for strategy in strategies:  # one from outside the package: a plan on this start
                    check_strategy(variant(base, replace(fleet, strategy=strategy)))
            except ScenarioError as exc:
                given = ", ".join(f"{k} = {v!r}" for k, v in fields.items())
                raise spec.fail(f"{ref}" + (f" with {given}" if given else "") + f": {exc}") from None
            for strategy in strategies:
                for seed in spec.seeds:
                    key = cell_key(base.name, data, strategy, seed, spec.draw_fleet, fingerprint(strategy),
                                   spec.platform)
                    scenario = variant(base, replace(fleet, strategy=strategy, seed=seed))
                    cells.append(Cell(len(cells), key, scenario, dict(point), strategy, seed,
                                      source_of(strategy), spec.platform))
    seen: dict[str, Cell] = {}
    for cell in cells:
        if cell.key in seen and spec.sensitivity is None:
            raise spec.fail(f"the same mission twice: {seen[cell.key].label} and {cell.label}")
        seen.setdefault(cell.key, cell)
    # A sensitivity sample may hold a point twice (an integer field rounded alike): one mission, which the
    # analysis finds for both by their values (`gcs.sweep.sensitivity`).
    return [replace(c, index=i) for i, c in enumerate(seen.values())] if spec.sensitivity is not None else cells


def _scenario_toml(spec: SweepSpec, ref: str) -> tuple[Path, dict[str, Any]]:
    """A scenario beside the spec, or as `vil run` finds it; checked as it is, then its TOML to patch."""
    beside = spec.path.parent / ref
    try:
        scenario = load_scenario(beside if beside.is_file() else ref)
    except ScenarioError as exc:
        raise spec.fail(f"sweep.scenarios: {exc}") from None
    return scenario.path, tomllib.loads(scenario.path.read_text(encoding="utf-8"))


def patched(raw: dict[str, Any], fields: dict[str, Value]) -> dict[str, Any]:
    """The scenario's TOML with each "table.field" set (on every aPad of an `[[apad]]` array)."""
    data = copy.deepcopy(raw)
    for name, value in fields.items():
        table, key = name.split(".")
        target = data.setdefault(table, {})
        for t in target if isinstance(target, list) else [target]:
            if isinstance(t, dict):  # not a table: the scenario's own check names the field
                t[key] = copy.deepcopy(value)
    return data


def cell_key(name: str, data: dict[str, Any], strategy: str, seed: int, draw_fleet: bool, code: str = "",
             platform: Platform = DEFAULT_PLATFORM) -> str:
    """`code`: a strategy from outside the package, its file's digest (an edited file: new cells)."""
    inputs = {"scenario": name, "fields": data, "strategy": strategy, "seed": seed, "draw_fleet": draw_fleet}
    if code:  # shipped strategies' keys stay what they were
        inputs["code"] = code
    if platform is not Platform.LOCKSTEP:  # lockstep cells' keys stay what they were
        inputs["platform"] = str(platform)
    text = json.dumps(inputs, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def run_cell(cell: Cell, runs_dir: str | None = None) -> dict[str, Any]:
    """On a worker: one mission on the cell's platform; its result.json and active-count series as plain data.

    `runs_dir`: keep the run's folder there (.tlog, logs, traces); without it the run writes nothing.
    """
    load_strategy(cell.strategy_source or cell.strategy)  # a worker process has loaded none yet
    series: dict[str, Any] = {}

    def keep_series(world: World) -> None:
        rec = world.fleet.recorder
        series.update(active_series(rec.step_time_us(), rec.active_count(), world.scenario.mission.duration_s,
                                    rec.start_us))

    out = Path(runs_dir) / f"{run_stem(cell.scenario)}-{cell.key}" if runs_dir is not None else None
    result = run_mission(cell.scenario, out, on_end=keep_series, platform=cell.platform)
    return {"result": result.to_json(), "series": series}


def active_series(time_us: NDArray[np.int64], active: NDArray[np.int32], duration_s: float,
                  start_us: int = 0) -> dict[str, Any]:
    """The active count's mean over bins of mission time (at most `SERIES_POINTS`), for bands across runs:
    each row (the count over a step ending at `time_us`, from the row before or `start_us`) weighed by the
    time it covers in each bin (lockstep's steps are one second each; the event platform's as long as
    nothing changes).

    Returns {"bin_s": width, "t_s": [end of each bin], "active": [mean count in it]}.
    """
    bin_s = max(SERIES_MIN_BIN_S, float(np.ceil(duration_s / SERIES_POINTS)))
    if active.size == 0:
        return {"bin_s": bin_s, "t_s": [], "active": []}
    knots = np.concatenate(([start_us], time_us)).astype(np.float64)
    area = np.concatenate(([0.0], np.cumsum(active * np.diff(knots))))  # the count integrated up to each knot
    width_us = bin_s * US_PER_S
    edges = np.arange(int(np.ceil(knots[-1] / width_us)) + 1) * width_us
    covered = np.diff(np.clip(edges, knots[0], knots[-1]))
    present = covered > 0
    means = np.diff(np.interp(edges, knots, area))[present] / covered[present]
    ends = np.minimum((np.flatnonzero(present) + 1) * bin_s, duration_s)
    return {"bin_s": bin_s, "t_s": ends.round(3).tolist(), "active": means.round(3).tolist()}
