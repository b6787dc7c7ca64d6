"""Scenario files: the shipped ones load; every kind of mistake is one line naming file and field."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from gcs.scenario.reader import ScenarioError, load_scenario, parse_duration_s

MISSIONS = Path(__file__).resolve().parents[2] / "missions"


def test_shipped_scenarios_load_with_the_papers_settings() -> None:
    pool = load_scenario(MISSIONS / "pool12.toml")
    assert (pool.name, pool.fleet.count, pool.mission.theta, pool.mission.duration_s) == ("pool12", 12, 30.0, 2400.0)
    assert (pool.mission.pool_threshold, pool.mission.charged_threshold) == (0.8, 0.99)
    bay = load_scenario("bay24")  # a bare name is looked up in missions/
    assert (bay.fleet.count, bay.mission.collect_strategy) == (24, "greedy")
    assert bay.fleet.area.name == "bay.geojson"


def test_overrides_replace_only_what_is_given() -> None:
    pool = load_scenario("pool12")
    other = pool.with_overrides(strategy="greedy", seed=7, duration_s=60.0)
    assert (other.mission.collect_strategy, other.seed, other.mission.duration_s) == ("greedy", 7, 60.0)
    assert other.mission.theta == pool.mission.theta and other.fleet == pool.fleet


@pytest.mark.parametrize(
    "text, expected",
    [("2400s", 2400.0), ("40m", 2400.0), ("40min", 2400.0), ("90s", 90.0), ("0.5h", 1800.0)],
)
def test_durations_with_units(text: str | int, expected: float) -> None:
    assert parse_duration_s(text) == expected


@pytest.mark.parametrize("text", ["40 minutes", "-5", "0", "fast", "40km", math.inf, math.nan, 1e300, "9999h",
                                  2400, "2400"])
def test_durations_with_wrong_units_are_refused(text: str | float) -> None:
    with pytest.raises(ValueError):
        parse_duration_s(text)


def write_variant(tmp_path: Path, old: str, new: str) -> Path:
    text = (MISSIONS / "pool12.toml").read_text()
    assert old in text
    path = tmp_path / "variant.toml"
    text = text.replace(old, new)
    # Paths in a scenario are relative to it: point them back at missions/.
    text = text.replace('"areas/', f'"{MISSIONS}/areas/').replace('"starts/', f'"{MISSIONS}/starts/')
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    "old, new, message",
    [
        ("count = 12", "count = -3", "fleet.count: -3 is outside [1, 65535]"),
        ("count = 12", 'count = "twelve"', "fleet.count: expected an integer"),
        ('duration = "40m"', 'duration = "40 parsecs"', "mission.duration: '40 parsecs' is not a duration"),
        ('collect_strategy = "cautious"', 'collect_strategy = "smart"',
         "mission.collect_strategy: unknown strategy 'smart'"),
        ("theta = 30 ", "theta = -30 ", "mission.theta: -30 is outside"),
        ('area = "areas/pool.geojson"', 'area = "areas/lake.geojson"', "fleet.area: no such file"),
        ("drift_cm = 0.5", "drift_cm = 0.5\ndrfit = 2", "fleet.drfit: unknown field"),
        ("home = [43.9400000, 15.4398381]", "home = [143.94, 15.44]", "apad.home: [143.94, 15.44] is not [lat, lon]"),
        ("start_battery = [0.6, 1.0]", "start_battery = [0.9, 0.6]", "fleet.start_battery: expected 0 <= min"),
        ("[environment]", "[environment]\nwind = 3", "environment.wind: unknown field"),
        # Non-finite and out-of-range numbers: TOML has nan and inf literals.
        ("pool_threshold = 0.80", "pool_threshold = nan", "mission.pool_threshold: nan is not a finite number"),
        ("charged_threshold = 0.99", "charged_threshold = -nan", "mission.charged_threshold: nan is not a finite"),
        ("theta = 30 ", "theta = inf ", "mission.theta: inf is not a finite number"),
        ("min_pool = 4", "min_pool = 4\ndistance_scale = inf", "mission.distance_scale: inf is not a finite number"),
        ("speed_mps = 0.5", "speed_mps = nan", "apad.speed_mps: nan is not a finite number"),
        ("acoustic_range_m = 100", "acoustic_range_m = inf", "fleet.acoustic_range_m: inf is not a finite number"),
        ("start_battery = [0.6, 1.0]", "start_battery = [nan, 1.0]", "fleet.start_battery: nan is not a finite"),
        ("current_mps = [0.0, 0.0]", "current_mps = [0.0, -inf]", "environment.current_mps: -inf is not a finite"),
        ("current_mps = [0.0, 0.0]", "current_mps = [300.0, 0.0]", "environment.current_mps: 300.0 is outside"),
        ("home = [43.9400000, 15.4398381]", "home = [nan, 15.44]", "apad.home: nan is not a finite number"),
        ('duration = "40m"', "duration = inf", "mission.duration: inf is not a duration"),
        ('duration = "40m"', "duration = 2400", 'mission.duration: 2400 has no unit: say "2400s", "2400min"'),
        ('duration = "40m"', 'duration = "100000h"', "mission.duration: 100000h is more than 90 days"),
        ("seed = 1", "seed = -1", "scenario.seed: -1 is outside [0, "),
    ],
)
def test_bad_fields_are_named_in_one_line(tmp_path: Path, old: str, new: str, message: str) -> None:
    path = write_variant(tmp_path, old, new)
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    text = str(err.value)
    assert text.startswith(f"{path}: ") and message in text and "\n" not in text


def test_broken_toml_and_missing_file(tmp_path: Path) -> None:
    broken = tmp_path / "broken.toml"
    broken.write_text("[mission\nduration = 3")
    with pytest.raises(ScenarioError, match="not valid TOML"):
        load_scenario(broken)
    with pytest.raises(ScenarioError, match="no such scenario file"):
        load_scenario(tmp_path / "nothing.toml")
