"""Scenario files: the shipped ones load; every kind of mistake is one line naming file and field."""

from __future__ import annotations

from pathlib import Path

import pytest

from gcs.mission.scenario import ScenarioError, load_scenario, parse_duration_s

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
    [(2400, 2400.0), ("2400", 2400.0), ("40m", 2400.0), ("40min", 2400.0), ("90s", 90.0), ("0.5h", 1800.0)],
)
def test_durations_with_units(text: str | int, expected: float) -> None:
    assert parse_duration_s(text) == expected


@pytest.mark.parametrize("text", ["40 minutes", "-5", "0", "fast", "40km"])
def test_durations_with_wrong_units_are_refused(text: str) -> None:
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
         "mission.collect_strategy: 'smart' is not one of"),
        ("theta = 30 ", "theta = -30 ", "mission.theta: -30 is outside"),
        ('area = "areas/pool.geojson"', 'area = "areas/lake.geojson"', "fleet.area: no such file"),
        ("drift_cm = 0.5", "drift_cm = 0.5\ndrfit = 2", "fleet.drfit: unknown field"),
        ("home = [43.9400000, 15.4398381]", "home = [143.94, 15.44]", "apad.home: [143.94, 15.44] is not [lat, lon]"),
        ("start_battery = [0.6, 1.0]", "start_battery = [0.9, 0.6]", "fleet.start_battery: expected 0 <= min"),
        ("[environment]", "[environment]\nwind = 3", "environment.wind: unknown field"),
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
