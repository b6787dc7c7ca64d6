"""`vil tune` specs: which policy fields a study searches, for which objective, on which seeds.

    [tune]
    name = "sleep-schedule"
    scenario = "bay-capacity"      # a name in missions/ or a file beside the spec
    strategy = "cautious"          # the tuned policy's strategy; its parameters are mission fields below
    baseline = "cautious"          # what the tuned policy is held against: the scenario with [set] alone
    objective = "uptime_min"       # an output of a mission (gcs.sweep.outputs.OUTPUTS)
    direction = "maximize"         # or "minimize" (e.g. apad_wh_per_day)
    no_depleted = true             # a trial in which any aMussel ran flat is infeasible (Optuna's constraints)
    trials = 40                    # complete trials the study holds when it is done
    seeds = "1-3"                  # tuning seeds: a trial's value is its objective's mean over them
    held_out = "101-120"           # the table's seeds, never tuned on
    platform = "event"             # what every mission runs on (docs/platforms.md)
    sampler_seed = 1

    [set]                          # fields of every mission (a sweep spec's [set])
    fleet.count = 32

    [search]                       # what the study searches: {min, max} (integers if both are) or a list
    mission.pool_threshold = {min = 0.5, max = 0.95}
    fleet.wake_interval_s = {min = 900, max = 7200}

Nothing here runs a mission: `gcs.tune.study` does, with the sweep's cells (each checked as `vil run` checks
a scenario) on the sweep's Dask cluster.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from gcs.mission.platform import Platform, platform_of
from gcs.scenario.reader import SEED_MAX, read_toml
from gcs.sweep.bounds import numeric_bounds
from gcs.sweep.outputs import OUTPUTS
from gcs.sweep.spec import SpecError, SweepSpec, Value, fields_of, seeds_of, table_of

MAX_TRIALS = 10_000


@dataclass(frozen=True)
class Range:
    """A searched field: a number in [low, high] (an integer if `integer`), or one of `choices`."""

    low: float = 0.0
    high: float = 0.0
    integer: bool = False
    choices: tuple[Value, ...] = ()


@dataclass(frozen=True)
class TuneSpec:
    path: Path
    name: str
    scenario: str
    strategy: str
    baseline: str
    objective: str
    direction: str  # Optuna's: "maximize" or "minimize"
    no_depleted: bool
    trials: int
    seeds: tuple[int, ...]
    held_out: tuple[int, ...]
    platform: Platform
    sampler_seed: int
    fixed: dict[str, Value]
    search: dict[str, Range]

    def corner(self) -> dict[str, Value]:
        """One policy of the search space (each field's low bound or first choice): checked before a study
        starts, so a misspelt field is one line, not a hundred failed trials."""
        return {k: r.choices[0] if r.choices else (int(r.low) if r.integer else r.low) for k, r in self.search.items()}

    def sweep(self, point: dict[str, Value], seeds: tuple[int, ...], strategy: str | None = None) -> SweepSpec:
        """The missions of one policy (`point`: searched fields' values) on `seeds`, as a sweep spec, so the
        sweep's cells check and key them (a mission run once is found again: DIR/cells)."""
        return SweepSpec(self.path, self.name, (self.scenario,), (strategy or self.strategy,), seeds, True,
                         self.fixed, tuple(point), (dict(point),), self.platform)


def load_tune_spec(path: str | Path) -> TuneSpec:
    """Read a tune spec and check its shape (the fields against the scenario: `gcs.tune.study`)."""
    path = Path(path)
    data = read_toml(path, SpecError, "tune spec")

    def fail(what: str) -> SpecError:
        return SpecError(f"{path}: {what}")

    unknown = sorted(set(data) - {"tune", "set", "search"})
    if unknown:
        raise fail(f"[{unknown[0]}]: unknown table (known: [tune], [set], [search])")
    top = data.get("tune")
    if not isinstance(top, dict):
        raise fail("[tune]: missing (the study's scenario, strategy, objective and seeds)")
    known = {"name", "scenario", "strategy", "baseline", "objective", "direction", "no_depleted", "trials", "seeds",
             "held_out", "platform", "sampler_seed"}
    for key in sorted(set(top) - known):
        raise fail(f"tune.{key}: unknown field")
    texts = {}
    for key in ("scenario", "strategy"):
        value = top.get(key)
        if not isinstance(value, str) or not value:
            raise fail(f"tune.{key}: expected a name, got {value!r}")
        texts[key] = value
    baseline = top.get("baseline", texts["strategy"])
    name = top.get("name", path.stem)
    if not isinstance(baseline, str) or not baseline or not isinstance(name, str) or not name:
        raise fail("tune.baseline and tune.name: expected names")
    objective = top.get("objective", "uptime_min")
    if objective not in OUTPUTS:
        raise fail(f"tune.objective: {objective!r} is not an output (known: {', '.join(OUTPUTS)})")
    direction = top.get("direction", "maximize")
    if direction not in ("maximize", "minimize"):
        raise fail(f"tune.direction: expected \"maximize\" or \"minimize\", got {direction!r}")
    no_depleted = top.get("no_depleted", True)
    if not isinstance(no_depleted, bool):
        raise fail(f"tune.no_depleted: expected true or false, got {no_depleted!r}")
    trials = top.get("trials", 40)
    if isinstance(trials, bool) or not isinstance(trials, int) or not 1 <= trials <= MAX_TRIALS:
        raise fail(f"tune.trials: expected an integer in [1, {MAX_TRIALS}], got {trials!r}")
    sampler_seed = top.get("sampler_seed", 0)
    if isinstance(sampler_seed, bool) or not isinstance(sampler_seed, int) or not 0 <= sampler_seed <= SEED_MAX:
        raise fail(f"tune.sampler_seed: expected an integer in [0, {SEED_MAX}], got {sampler_seed!r}")
    seeds = seeds_of(top.get("seeds", [1]), lambda what: fail(what.replace("sweep.seeds", "tune.seeds")))
    held_out = seeds_of(top.get("held_out", "101-120"), lambda what: fail(what.replace("sweep.seeds", "tune.held_out")))
    both = sorted(set(seeds) & set(held_out))
    if both:
        raise fail(f"tune.held_out: seed {both[0]} is also a tuning seed (held-out seeds are never tuned on)")
    try:
        platform = platform_of(top.get("platform", "event"))
    except (ValueError, TypeError) as exc:
        raise fail(f"tune.platform: {exc}") from None
    fixed = fields_of(table_of(data, "set", fail), "set", fail)
    search = {key: _range(key, value, fail) for key, value in fields_of(table_of(data, "search", fail), "search",
                                                                          fail).items()}
    if not search:
        raise fail("[search]: nothing to search (add e.g. mission.pool_threshold = {min = 0.5, max = 0.95})")
    twice = sorted(set(fixed) & set(search))
    if twice:
        raise fail(f"{twice[0]}: set in both [set] and [search]")
    return TuneSpec(path.resolve(), name, texts["scenario"], texts["strategy"], baseline, objective, direction,
                    no_depleted, trials, seeds, held_out, platform, sampler_seed, fixed, search)


def _range(key: str, value: Any, fail: Any) -> Range:
    if isinstance(value, list) and value:
        return Range(choices=tuple(value))
    found = numeric_bounds(value)
    if found is not None and found[0] < found[1]:
        return Range(*found)
    raise fail(f"search.{key}: expected {{min = A, max = B}} with numbers A < B, or a non-empty list, got {value!r}")
