"""Sweep specs: which scenarios, strategies, seeds and parameter points a sweep runs.

    [sweep]
    scenarios = ["pool12", "bay24"]   # names in missions/ or files (relative to the spec)
    strategies = "all"                # or a list; "all" = every collect strategy registered now
    seeds = "1-20"                    # a range "A-B", or a list of integers
    draw_fleet = true                 # each seed draws its fleet (as `vil run --seeds`); false: the saved start
    platform = "event"                # or "lockstep" (the default): what every cell runs on (docs/platforms.md)

    [set]                             # the same in every cell
    mission.duration = "20m"

    [grid]                            # every combination of these values
    mission.pool_threshold = [0.7, 0.8, 0.9]

    [[grid]]                          # or several blocks, each a grid of its own (the same fields in
    fleet.profile = ["always_on"]     # each): the points of all of them, e.g. counts per profile
    fleet.count = [4, 8]
    [[grid]]
    fleet.profile = ["hourly_wake"]
    fleet.count = [48, 96]

    [sample]                          # n points drawn at random (seeded), crossed with the grid
    n = 8
    seed = 1
    mission.theta = {min = 10, max = 60}    # uniform in [min, max] (integers if both are)
    apad.speed_mps = [0.3, 0.5]             # a list: one of these

    [sensitivity]                     # or SALib's sample for a sensitivity study, alone (no [grid], no
    method = "sobol"                  # [sample]): gcs.sweep.sensitivity_design, docs/sensitivity.md
    n = 256
    mission.pool_threshold = {min = 0.6, max = 0.9}
    apad.speed_mps = {min = 0.3, max = 0.8}

A field is TABLE.FIELD of a scenario file; under `[[apad]]` (several aPads) it is set on each.
Nothing here runs a mission: `gcs.sweep.cells` turns a spec into the missions, checking each one.
"""

from __future__ import annotations

import itertools
import re
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from gcs.mission.platform import DEFAULT_PLATFORM, Platform, platform_of
from gcs.scenario.reader import SEED_MAX, read_toml
from gcs.sweep import sensitivity_design
from gcs.sweep.bounds import is_range, numeric_bounds
from gcs.sweep.sensitivity_design import Design

MAX_CELLS = 100_000  # more is a typo in a range, not a sweep this machine should start
MAX_SAMPLE = 10_000
_SEED_RANGE = re.compile(r"^\s*(\d+)\s*-\s*(\d+)\s*$")
# Fields a sweep sets itself: the strategy and the seed are axes of their own, the name identifies the scenario.
RESERVED = {
    "scenario.seed": "use [sweep] seeds",
    "scenario.name": "a sweep names its rows by the scenario's own name",
    "mission.collect_strategy": "use [sweep] strategies",
}

Value = Any  # a TOML value: number, string, boolean, list


class SpecError(ValueError):
    """One line for the user: the spec file, the entry, what is wrong."""


@dataclass(frozen=True)
class SweepSpec:
    path: Path
    name: str
    scenarios: tuple[str, ...]  # as written; `gcs.sweep.cells` finds and checks them
    strategies: tuple[str, ...] | None  # None: every registered collect strategy, read when the cells are made
    seeds: tuple[int, ...]
    draw_fleet: bool
    fixed: dict[str, Value]  # [set]: field -> value
    swept: tuple[str, ...]  # the fields that vary, grid first, then sample
    points: tuple[dict[str, Value], ...]  # one dict of swept values per point (one empty point if none)
    platform: Platform = DEFAULT_PLATFORM
    sensitivity: Design | None = None  # a [sensitivity] study: its points are SALib's sample, in order

    def fail(self, what: str) -> SpecError:
        return SpecError(f"{self.path}: {what}")

    def first_seeds(self, n: int) -> SweepSpec:
        """The same sweep on its first `n` seeds only (`vil sweep --seeds N`): each cell is the whole
        spec's cell, so a later sweep of every seed into the same folder keeps them."""
        return replace(self, seeds=self.seeds[:n])

    def first_base_samples(self, n: int) -> SweepSpec:
        """A [sensitivity] study on its first `n` base samples (`vil sweep --base-samples N`): Saltelli's and
        Morris's samples of n are the first points of the whole spec's, so a later run of all of them keeps
        these. SpecError if the spec has no such study or `n` does not fit it."""
        design = self.sensitivity
        if design is None:
            raise self.fail("--base-samples: the spec has no [sensitivity] table")
        if n > design.n or (design.method == "sobol" and n & (n - 1)):
            raise self.fail(f"--base-samples: {n} is not a power of 2 up to the spec's n = {design.n}")
        smaller = replace(design, n=n)
        return replace(self, sensitivity=smaller, points=tuple(smaller.points()))


def load_spec(path: str | Path) -> SweepSpec:
    """Read a sweep spec and check its shape (fields are checked against each scenario by `cells`)."""
    path = Path(path)
    data = read_toml(path, SpecError, "sweep spec")

    def fail(what: str) -> SpecError:
        return SpecError(f"{path}: {what}")

    unknown = sorted(set(data) - {"sweep", "set", "grid", "sample", "sensitivity"})
    if unknown:
        raise fail(f"[{unknown[0]}]: unknown table (known: [sweep], [set], [grid], [sample], [sensitivity])")
    top = table_of(data, "sweep", fail)
    for key in sorted(set(top) - {"name", "scenarios", "strategies", "seeds", "draw_fleet", "platform"}):
        raise fail(f"sweep.{key}: unknown field")
    name = top.get("name", path.stem)
    if not isinstance(name, str) or not name:
        raise fail(f"sweep.name: expected a string, got {name!r}")
    scenarios = top.get("scenarios")
    if not isinstance(scenarios, list) or not scenarios or not all(isinstance(s, str) for s in scenarios):
        raise fail(f"sweep.scenarios: expected a list of scenario names or files, got {scenarios!r}")
    if len(set(scenarios)) != len(scenarios):
        raise fail(f"sweep.scenarios: a scenario twice in {scenarios}")
    strategies = _strategies(top.get("strategies", "all"), fail)
    seeds = seeds_of(top.get("seeds", [1]), fail)
    draw_fleet = top.get("draw_fleet", True)
    if not isinstance(draw_fleet, bool):
        raise fail(f"sweep.draw_fleet: expected true or false, got {draw_fleet!r}")
    try:
        platform = platform_of(top.get("platform", str(DEFAULT_PLATFORM)))
    except (ValueError, TypeError) as exc:
        raise fail(f"sweep.platform: {exc}") from None

    fixed = fields_of(table_of(data, "set", fail), "set", fail)
    if "sensitivity" in data:
        return _sensitivity_spec(path, data, fixed, fail, (name, tuple(scenarios), strategies, seeds, draw_fleet),
                                 platform)
    blocks = _grids(data.get("grid", {}), fail)
    grid = blocks[0]
    sample_table = dict(table_of(data, "sample", fail))
    sampled = _sample(sample_table, fail) if sample_table else []
    sampled_keys = list(sampled[0]) if sampled else []
    twice = sorted((set(fixed) & {*grid, *sampled_keys}) | (set(grid) & set(sampled_keys)))
    if twice:
        raise fail(f"{twice[0]}: set in more than one of [set], [grid], [sample]")
    swept = (*grid, *sampled_keys)
    points = [dict(zip(block, combo, strict=True)) for block in blocks
              for combo in itertools.product(*block.values())]
    if sampled:
        points = [p | s for p in points for s in sampled]
    n_strategies = len(strategies) if strategies is not None else 1
    n_cells = len(scenarios) * len(points) * n_strategies * len(seeds)
    if n_cells > MAX_CELLS:
        raise fail(f"{n_cells} missions is more than {MAX_CELLS}; narrow the grid or the seeds")
    return SweepSpec(path.resolve(), name, tuple(scenarios), strategies, seeds, draw_fleet, fixed, swept,
                     tuple(points), platform)


def _sensitivity_spec(path: Path, data: dict[str, Any], fixed: dict[str, Value], fail: Any,
                      head: tuple[str, tuple[str, ...], tuple[str, ...] | None, tuple[int, ...], bool],
                      platform: Platform) -> SweepSpec:
    """A spec whose points are a [sensitivity] table's sample (with neither [grid] nor [sample])."""
    for other in ("grid", "sample"):
        if other in data:
            raise fail(f"[{other}]: a [sensitivity] study samples its own points; drop [{other}] or split the spec")
    design = sensitivity_design.parse(table_of(data, "sensitivity", fail),
                                      lambda table, where: fields_of(table, where, fail), fail)
    twice = sorted(set(fixed) & set(design.names))
    if twice:
        raise fail(f"{twice[0]}: set in both [set] and [sensitivity]")
    name, scenarios, strategies, seeds, draw_fleet = head
    n_cells = len(scenarios) * design.size() * (len(strategies) if strategies is not None else 1) * len(seeds)
    if n_cells > MAX_CELLS:
        raise fail(f"{n_cells} missions is more than {MAX_CELLS}; lower sensitivity.n or the seeds")
    return SweepSpec(path.resolve(), name, scenarios, strategies, seeds, draw_fleet, fixed, design.names,
                     tuple(design.points()), platform, design)


def table_of(data: dict[str, Any], key: str, fail: Any) -> dict[str, Any]:
    value = data.get(key, {})
    if not isinstance(value, dict):
        raise fail(f"{key}: expected a table [{key}]")
    return value


def _grids(value: Any, fail: Any) -> list[dict[str, Value]]:
    """[grid] as one block, or [[grid]] as several (each a product of its own; every block sweeps the
    same fields, so every row has every column). Shape: the blocks, each field -> its values."""
    tables = value if isinstance(value, list) else [value]
    if not tables or not all(isinstance(t, dict) for t in tables):
        raise fail("grid: expected a table [grid] or tables [[grid]]")
    blocks = [fields_of(t, "grid", fail) for t in tables]
    for block in blocks:
        for key, values in block.items():
            if not isinstance(values, list) or not values:
                raise fail(f"grid.{key}: expected a non-empty list of values, got {values!r}")
        if set(block) != set(blocks[0]):
            raise fail(f"grid: every [[grid]] block sweeps the same fields ({', '.join(blocks[0]) or 'none'}), "
                       f"one sweeps {', '.join(block) or 'none'}")
    return [{k: block[k] for k in blocks[0]} for block in blocks]  # one column order


def fields_of(table: dict[str, Any], where: str, fail: Any) -> dict[str, Value]:
    """Scenario fields as "table.field" keys: `mission.theta = 1` and `"mission.theta" = 1` alike."""
    out: dict[str, Value] = {}
    for key, value in table.items():
        if "." not in key and isinstance(value, dict):
            for sub, v in value.items():
                out[f"{key}.{sub}"] = v
        else:
            out[key] = value
    for key in out:
        parts = key.split(".")
        if len(parts) != 2 or not all(parts):
            raise fail(f"{where}.{key}: expected a scenario field as TABLE.FIELD (e.g. mission.theta)")
        if key in RESERVED:
            raise fail(f"{where}.{key}: not a sweep field ({RESERVED[key]})")
    return out


def _strategies(value: Any, fail: Any) -> tuple[str, ...] | None:
    if value == "all":
        return None
    if not isinstance(value, list) or not value or not all(isinstance(v, str) and v for v in value):
        raise fail(f'sweep.strategies: expected "all" or a list of strategy names, got {value!r}')
    if len(set(value)) != len(value):
        raise fail(f"sweep.strategies: a strategy twice in {value}")
    return tuple(value)


def seeds_of(value: Any, fail: Any) -> tuple[int, ...]:
    if isinstance(value, str):
        match = _SEED_RANGE.match(value)
        if not match or int(match.group(1)) > int(match.group(2)):
            raise fail(f'sweep.seeds: {value!r} is not a range "FIRST-LAST" (e.g. "1-20")')
        seeds = list(range(int(match.group(1)), int(match.group(2)) + 1))
    elif isinstance(value, int) and not isinstance(value, bool):
        seeds = [value]
    elif isinstance(value, list) and value and all(isinstance(v, int) and not isinstance(v, bool) for v in value):
        seeds = list(value)
    else:
        raise fail(f'sweep.seeds: expected a range "FIRST-LAST" or a list of integers, got {value!r}')
    bad = [s for s in seeds if not 0 <= s <= SEED_MAX]
    if bad:
        raise fail(f"sweep.seeds: {bad[0]} is outside [0, {SEED_MAX}]")
    if len(set(seeds)) != len(seeds):
        raise fail(f"sweep.seeds: a seed twice in {value!r}")
    if len(seeds) > MAX_CELLS:
        raise fail(f"sweep.seeds: {len(seeds)} seeds is more than {MAX_CELLS}")
    return tuple(seeds)


def _sample(table: dict[str, Any], fail: Any) -> list[dict[str, Value]]:
    """`n` points drawn with the table's `seed`: each field uniform in {min, max} or one of a list."""
    n = table.pop("n", None)
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= MAX_SAMPLE:
        raise fail(f"sample.n: expected an integer in [1, {MAX_SAMPLE}], got {n!r}")
    seed = table.pop("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= SEED_MAX:
        raise fail(f"sample.seed: expected an integer in [0, {SEED_MAX}], got {seed!r}")
    fields: dict[str, Value] = {}
    for key, value in table.items():  # a {min, max} table is a range, not a scenario table
        if "." not in key and isinstance(value, dict) and not is_range(value):
            fields |= {f"{key}.{sub}": v for sub, v in value.items()}
        else:
            fields[key] = value
    fields = fields_of(fields, "sample", fail)
    if not fields:
        raise fail("sample: no field to sample (add e.g. mission.theta = {min = 10, max = 60})")
    for key, value in fields.items():
        if is_range(value):
            found = numeric_bounds(value)
            if found is None or found[0] > found[1]:
                raise fail(f"sample.{key}: expected {{min = A, max = B}} with numbers A <= B, got {value!r}")
        elif not isinstance(value, list) or not value:
            raise fail(f"sample.{key}: expected {{min = A, max = B}} or a non-empty list of values, got {value!r}")
    rng = np.random.default_rng(seed)
    points = []
    for _ in range(n):
        point: dict[str, Value] = {}
        for key in sorted(fields):  # a fixed order of draws: the same spec draws the same points
            value = fields[key]
            if not is_range(value):
                point[key] = value[int(rng.integers(len(value)))]
            elif isinstance(value["min"], int) and isinstance(value["max"], int):
                point[key] = int(rng.integers(value["min"], value["max"] + 1))
            else:
                point[key] = float(f"{rng.uniform(value['min'], value['max']):.6g}")  # readable in tables
        points.append({k: point[k] for k in fields})
    return points
