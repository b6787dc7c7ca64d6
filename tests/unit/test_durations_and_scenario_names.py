"""Sane defaults (issue 14): a duration always carries its unit; a scenario is found from the working
directory first, then among the shipped missions/; what `--seed` changes is said in words."""

from __future__ import annotations

import argparse
import math
import os
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import pytest
from testkit import scenario_variant

from gcs.cli import flags
from gcs.mission.start import RunOptions, seed_notice, variant
from gcs.scenario.reader import MISSIONS_DIR, ScenarioError, load_scenario, resolve_scenario
from missiontime.durations import parse_duration_s


@pytest.mark.parametrize("text, seconds", [
    ("90s", 90.0), ("40min", 2400.0), ("40m", 2400.0), ("1h", 3600.0), ("1.5h", 5400.0), ("200ms", 0.2),
    (" 2 min ", 120.0), (".5s", 0.5), ("168h", 7 * 86400.0), ("7d", 7 * 86400.0), ("1.5d", 1.5 * 86400.0),
])
def test_a_duration_with_its_unit_is_read_in_seconds(text: str, seconds: float) -> None:
    assert parse_duration_s(text) == pytest.approx(seconds)


@pytest.mark.parametrize("text, message", [
    ("40", "40 has no unit: say 40s, 40min or 40h"),
    ("0.2", "0.2 has no unit: say 0.2s, 0.2min or 0.2h"),
    (2400, 'has no unit: say "2400s", "2400min" or "2400h"'),  # a number in a scenario file
    ("40 minutes", "'40 minutes' is not a duration: say e.g. 90s, 40min or 1.5h"),
    ("40km", "is not a duration"),
    ("1e3s", "is not a duration"),
    ("inf", "is not a duration"),
    (math.nan, "is not a duration"),
    (True, "is not a duration"),
    ("-5s", "-5s is not a positive duration"),
    ("0s", "0s is not a positive duration"),
    ("2161h", "2161h is more than 90 days"), ("91d", "91d is more than 90 days"),
])
def test_a_duration_without_its_unit_or_out_of_range_is_refused_in_one_line(text: object, message: str) -> None:
    with pytest.raises(ValueError) as exc:
        parse_duration_s(text)
    assert message in str(exc.value) and "\n" not in str(exc.value)


def test_the_flags_read_lengths_and_moments_of_the_mission_with_units() -> None:
    assert flags.duration("15min") == 900.0
    assert flags.duration_up_to(5.0)("0s") == 0.0 and flags.duration_up_to(5.0)("200ms") == pytest.approx(0.2)
    assert flags.mission_time("0s") == 0.0
    assert flags.window("92s:112s") == (92.0, 112.0)
    assert flags.apad_at("3:10min") == (3, 600.0)
    for parse, text, message in [
        (flags.duration, "40", "40 has no unit"),
        (flags.duration_up_to(5.0), "6s", "6s is more than 5 s"),
        (flags.window, "92:112", "START:END 92:112: 92 has no unit"),
        (flags.window, "112s:92s", "START before END"),
        (flags.apad_at, "3:600", "SYSID:T 3:600: 600 has no unit"),
        (flags.apad_at, "300:1s", "1 <= SYSID <= 249"),
    ]:
        with pytest.raises(argparse.ArgumentTypeError, match=message):
            parse(text)


@pytest.fixture()
def in_tmp(tmp_path: Path) -> Iterator[Path]:
    before = Path.cwd()
    os.chdir(tmp_path)
    try:
        yield tmp_path
    finally:
        os.chdir(before)


def local_variant(folder: Path, name: str) -> Path:
    """A copy of pool12 named `name` in `folder`, its files pointing back at missions/."""
    return scenario_variant("pool12", folder / f"{name}.toml", {'name = "pool12"': f'name = "{name}"'})


def test_a_scenario_is_found_in_the_working_directory_first_then_in_the_shipped_missions(in_tmp: Path) -> None:
    shipped = MISSIONS_DIR / "pool12.toml"
    for name in ("pool12", "pool12.toml", "missions/pool12.toml", "missions/pool12", str(shipped)):
        assert resolve_scenario(name) == shipped, name  # nothing of that name here
    (in_tmp / "missions").mkdir()
    mine = local_variant(in_tmp, "pool12")
    local_variant(in_tmp / "missions", "pool12")
    assert resolve_scenario("pool12") == Path("pool12.toml") and load_scenario("pool12").path == mine.resolve()
    assert resolve_scenario("pool12.toml") == Path("pool12.toml")
    assert resolve_scenario("missions/pool12.toml") == Path("missions/pool12.toml")  # this folder's missions/
    local_variant(in_tmp, "mine")
    assert load_scenario("mine").name == "mine"  # a name without .toml, here
    assert load_scenario("bay24").fleet.count == 24  # still the shipped one when not here


def test_a_scenario_found_nowhere_is_one_line_listing_the_shipped_ones(in_tmp: Path) -> None:
    with pytest.raises(ScenarioError) as exc:
        load_scenario("pool13")
    message = str(exc.value)
    assert message.startswith(f"pool13: no such scenario file, here or in {MISSIONS_DIR}; did you mean pool12? "
                              "(shipped: ")
    assert "bay24, bay24-acoustic, pool12, pool12-acoustic, pool12x2" in message and "\n" not in message
    with pytest.raises(ScenarioError) as far:
        load_scenario("lagoon")
    assert str(far.value).startswith(f"lagoon: no such scenario file, here or in {MISSIONS_DIR} (shipped: ")


@pytest.mark.parametrize("given, meant", [("Pool12", "pool12"), ("pool21", "pool12"), ("missions/Bay24.toml", "bay24"),
                                          ("bay120-slep", "bay120-sleep")])
def test_a_misspelt_scenario_name_gets_the_closest_shipped_one(in_tmp: Path, given: str, meant: str) -> None:
    with pytest.raises(ScenarioError, match=f"; did you mean {meant}\\? \\(shipped: "):
        load_scenario(given)


def test_a_copy_of_a_shipped_scenario_runs_under_its_own_file_name(in_tmp: Path) -> None:
    """`cp missions/pool12.toml mine.toml`: the copy's `name = "pool12"` came along with the rest; its runs
    are not pool12's (run folders, --resume). A name of one's own, and the shipped file itself, keep theirs."""
    copied = scenario_variant("pool12", in_tmp / "mine.toml", {})
    assert 'name = "pool12"' in copied.read_text()
    assert load_scenario("mine.toml").name == "mine"
    assert load_scenario("pool12").name == "pool12" and load_scenario(MISSIONS_DIR / "pool12.toml").name == "pool12"
    assert load_scenario(local_variant(in_tmp, "lagoon")).name == "lagoon"  # name = "lagoon": its own
    own = scenario_variant("pool12", in_tmp / "trial.toml", {'name = "pool12"': 'name = "pool12-night"'})
    assert load_scenario(own).name == "pool12-night"  # not a shipped name: kept
    (in_tmp / "elsewhere").mkdir()
    same_stem = scenario_variant("pool12", in_tmp / "elsewhere" / "pool12.toml", {})
    assert load_scenario(same_stem).name == "pool12"  # the file says pool12 and is called so


def test_vil_run_help_lists_every_shipped_scenario(capsys: pytest.CaptureFixture[str]) -> None:
    from gcs.cli.main import main

    with pytest.raises(SystemExit):
        main(["run", "--help"])
    text = "".join(capsys.readouterr().out.split())  # argparse wraps lines, at hyphens too
    shipped = sorted(p.stem for p in MISSIONS_DIR.glob("*.toml"))
    assert len(shipped) >= 10 and f"({','.join(shipped)})" in text


def test_the_seed_notice_says_exactly_what_a_seed_changes_over_a_saved_fleet() -> None:
    pool = load_scenario("pool12")
    assert seed_notice(pool, None, faults=False) is None  # no --seed: nothing to say
    assert seed_notice(variant(pool, RunOptions(draw_fleet=True)), 3, faults=False) is None
    assert seed_notice(pool, 3, faults=False) == (
        "pool12's fleet is its saved start configuration (pool12.geojson): --seed 3 changes only the aMussels' "
        "random drift (up to 0.5 cm a step); add --draw-fleet to draw the fleet from the seed too")
    swarm = seed_notice(load_scenario("pool12x2"), 3, faults=True)
    assert swarm is not None and ("drift (up to 0.5 cm a step), where the swarm's k-means sharing starts and the "
                                  "link faults' draws;") in swarm
    still = replace(pool, fleet=replace(pool.fleet, drift_cm=0.0))
    assert "--seed 3 changes nothing in this run" in str(seed_notice(still, 3, faults=False))
