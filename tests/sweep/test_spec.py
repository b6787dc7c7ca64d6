"""Sweep specs: what a spec means (cells, keys, points) and the one line each bad spec gets."""

from __future__ import annotations

from pathlib import Path

import pytest

from gcs.strategies import shipped_names
from gcs.sweep.cells import make_cells
from gcs.sweep.spec import SpecError, load_spec

MISSIONS = Path(__file__).resolve().parents[2] / "missions"


def spec_file(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "spec.toml"
    path.write_text(text)
    return path


def test_grid_seeds_and_all_strategies_make_one_cell_each(tmp_path: Path) -> None:
    spec = load_spec(spec_file(tmp_path, """
[sweep]
scenarios = ["pool12", "bay24"]
strategies = "all"
seeds = "3-5"
[set]
mission.duration = "10m"
[grid]
"mission.pool_threshold" = [0.7, 0.9]
fleet.drift_cm = [0.5]
"""))
    cells = make_cells(spec)
    strategies = shipped_names()
    assert {"greedy", "cautious", "none"} <= set(strategies)
    assert len(cells) == 2 * 2 * len(strategies) * 3
    assert spec.swept == ("mission.pool_threshold", "fleet.drift_cm")
    first = cells[0]
    assert (first.scenario.name, first.strategy, first.seed) == ("pool12", strategies[0], 3)
    assert first.values == {"mission.pool_threshold": 0.7, "fleet.drift_cm": 0.5}
    assert first.scenario.mission.pool_threshold == 0.7
    assert first.scenario.mission.duration_s == 600.0
    assert first.scenario.fleet.start_config is None  # draw_fleet by default
    assert cells[-1].scenario.name == "bay24" and cells[-1].scenario.mission.pool_threshold == 0.9
    assert [c.index for c in cells] == list(range(len(cells)))
    assert len({c.key for c in cells}) == len(cells)
    # The same spec again gives the same keys: a finished cell is found again.
    assert [c.key for c in make_cells(load_spec(spec.path))] == [c.key for c in cells]


def test_a_changed_fixed_field_is_a_new_cell(tmp_path: Path) -> None:
    base = '[sweep]\nscenarios = ["pool12"]\nstrategies = ["greedy"]\nseeds = [1]\n'
    a = make_cells(load_spec(spec_file(tmp_path, base + '[set]\nmission.duration = "10m"\n')))
    b = make_cells(load_spec(spec_file(tmp_path, base + '[set]\nmission.duration = "11m"\n')))
    assert a[0].key != b[0].key


def test_sample_is_seeded_and_in_range(tmp_path: Path) -> None:
    text = """
[sweep]
scenarios = ["pool12"]
strategies = ["greedy"]
[sample]
n = 5
seed = 7
mission.theta = {min = 10.0, max = 60.0}
fleet.count = {min = 8, max = 12}
apad.speed_mps = [0.3, 0.5]
"""
    spec = load_spec(spec_file(tmp_path, text))
    assert spec.points == load_spec(spec.path).points
    assert len(spec.points) == 5
    for p in spec.points:
        assert 10 <= p["mission.theta"] <= 60 and isinstance(p["mission.theta"], float)
        assert p["fleet.count"] in range(8, 13) and isinstance(p["fleet.count"], int)
        assert p["apad.speed_mps"] in (0.3, 0.5)
    cells = make_cells(spec)
    assert [c.scenario.fleet.count for c in cells] == [p["fleet.count"] for p in spec.points]
    assert [c.scenario.apad.speed_mps for c in cells] == [p["apad.speed_mps"] for p in spec.points]


def test_a_swarm_field_is_set_on_every_apad(tmp_path: Path) -> None:
    spec = load_spec(spec_file(tmp_path, '[sweep]\nscenarios = ["pool12x2"]\nstrategies = ["greedy"]\n'
                                         '[grid]\napad.speed_mps = [0.7]\n'))
    (cell,) = make_cells(spec)
    assert len(cell.scenario.apads) == 2 and {a.speed_mps for a in cell.scenario.apads} == {0.7}


@pytest.mark.parametrize(("text", "message"), [
    ('[sweep]\nscenarios = ["pool12"]\n[grid]\nmission.foo = [1]\n', "mission.foo: unknown field"),
    ('[sweep]\nscenarios = ["pool12"]\n[grid]\nmission.theta = [0]\n', "mission.theta: 0 is outside"),
    ('[sweep]\nscenarios = ["pool12"]\n[set]\nmission.pool_threshold = "high"\n', "expected a number"),
    ('[sweep]\nscenarios = ["pool12"]\n[set]\nwaves.height = 1\n', "waves: unknown field"),
    ('[sweep]\nscenarios = ["pool12"]\ndraw_fleet = false\n[grid]\nfleet.count = [8]\n',
     "holds 12 aMussels, the scenario says 8"),
    ('[sweep]\nscenarios = ["pool12"]\nstrategies = ["fastest"]\n', "sweep.strategies: unknown strategy 'fastest'"),
    ('[sweep]\nscenarios = ["nowhere"]\n', "sweep.scenarios: nowhere"),
    ('[sweep]\nscenarios = ["pool12"]\nseeds = "20-1"\n', 'is not a range "FIRST-LAST"'),
    ('[sweep]\nscenarios = ["pool12"]\nseeds = [1, 1]\n', "a seed twice"),
    ('[sweep]\nscenarios = ["pool12"]\nseeds = "1-200000"\n', "more than 100000"),
    ('[sweep]\nscenarios = ["pool12"]\nspeed = 1\n', "sweep.speed: unknown field"),
    ('[sweep]\nscenarios = ["pool12"]\n[grids]\n', "[grids]: unknown table"),
    ('[sweep]\nscenarios = []\n', "sweep.scenarios: expected a list"),
    ('[sweep]\nscenarios = ["pool12"]\n[grid]\nmission.theta = []\n', "grid.mission.theta: expected a non-empty list"),
    ('[sweep]\nscenarios = ["pool12"]\n[grid]\n"theta" = [1]\n', "expected a scenario field as TABLE.FIELD"),
    ('[sweep]\nscenarios = ["pool12"]\n[grid]\nscenario.seed = [1]\n', "use [sweep] seeds"),
    ('[sweep]\nscenarios = ["pool12"]\n[grid]\nmission.collect_strategy = ["greedy"]\n', "use [sweep] strategies"),
    ('[sweep]\nscenarios = ["pool12"]\n[set]\nmission.theta = 5\n[grid]\nmission.theta = [6]\n',
     "mission.theta: set in more than one"),
    ('[sweep]\nscenarios = ["pool12"]\n[sample]\nn = 0\nmission.theta = {min = 1, max = 2}\n', "sample.n"),
    ('[sweep]\nscenarios = ["pool12"]\n[sample]\nn = 2\nmission.theta = {min = 3, max = 2}\n', "A <= B"),
    ('[sweep]\nscenarios = ["pool12"]\n[sample]\nn = 2\n', "no field to sample"),
    ("[sweep\n", "not valid TOML"),
])
def test_bad_specs_get_one_line(tmp_path: Path, text: str, message: str) -> None:
    with pytest.raises(SpecError) as err:
        make_cells(load_spec(spec_file(tmp_path, text)))
    assert message in str(err.value)
    assert "\n" not in str(err.value)
    assert str(err.value).startswith(str(tmp_path))


def test_first_seeds_are_the_whole_specs_cells_for_those_seeds() -> None:
    spec = load_spec(MISSIONS / "sweeps" / "strategies.toml")
    whole = {(c.scenario.name, c.strategy, c.seed): c.key for c in make_cells(spec)}
    cut = make_cells(spec.first_seeds(2))
    assert {c.seed for c in cut} == {1, 2} and len(cut) == 2 * len(shipped_names()) * 2
    assert all(whole[(c.scenario.name, c.strategy, c.seed)] == c.key for c in cut)  # the same missions, kept later
    assert spec.first_seeds(50).seeds == spec.seeds


def test_the_quick_spec_is_small_and_a_first_try() -> None:
    """missions/sweeps/quick.toml, the docs' first sweep: the paper's three strategies on pool12, 5 drawn fleets,
    the paper's 40 minutes: 15 missions (strategies.toml's smallest is 360; capacity's are hours each)."""
    cells = make_cells(load_spec(MISSIONS / "sweeps" / "quick.toml"))
    assert len(cells) == 15 and {c.scenario.name for c in cells} == {"pool12"}
    assert {c.strategy for c in cells} == {"cautious", "greedy", "none"}
    assert {c.scenario.mission.duration_s for c in cells} == {2400.0} and {c.seed for c in cells} == set(range(1, 6))


def test_the_shipped_strategies_sweep_is_valid() -> None:
    spec = load_spec(MISSIONS / "sweeps" / "strategies.toml")
    cells = make_cells(spec)
    assert {c.scenario.name for c in cells} == {"pool12", "bay24"}
    assert {c.strategy for c in cells} == set(shipped_names())
    assert {c.seed for c in cells} == set(range(1, 21))
    assert len(cells) == 2 * len(shipped_names()) * 20 >= 160


def test_grid_blocks_sweep_counts_per_profile_and_the_capacity_spec_parses(tmp_path: Path) -> None:
    """[[grid]] blocks: each a grid of its own, their points one after the other (issue 20's capacity study)."""
    spec = load_spec(spec_file(tmp_path, """
[sweep]
scenarios = ["pool12"]
strategies = ["cautious"]
seeds = [1]
[[grid]]
fleet.profile = ["always_on"]
fleet.count = [4, 8]
[[grid]]
fleet.count = [48]
fleet.profile = ["hourly_wake"]
"""))
    assert spec.swept == ("fleet.profile", "fleet.count")
    assert spec.points == ({"fleet.profile": "always_on", "fleet.count": 4},
                           {"fleet.profile": "always_on", "fleet.count": 8},
                           {"fleet.profile": "hourly_wake", "fleet.count": 48})
    cells = make_cells(spec)
    assert [(c.scenario.fleet.profile, c.scenario.fleet.count) for c in cells] == [
        ("always_on", 4), ("always_on", 8), ("hourly_wake", 48)]
    capacity = load_spec(MISSIONS / "sweeps" / "capacity.toml")
    shipped = make_cells(capacity)
    assert {c.scenario.mission.duration_s for c in shipped} == {86400.0}
    assert {c.scenario.fleet.profile for c in shipped} == {"always_on", "hourly_wake"}
    assert all(len(c.scenario.apads) == 1 for c in shipped)


def test_grid_blocks_must_sweep_the_same_fields(tmp_path: Path) -> None:
    with pytest.raises(SpecError, match="every \\[\\[grid\\]\\] block sweeps the same fields"):
        load_spec(spec_file(tmp_path, """
[sweep]
scenarios = ["pool12"]
[[grid]]
fleet.count = [4]
[[grid]]
fleet.profile = ["hourly_wake"]
"""))
