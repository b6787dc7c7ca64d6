"""The aPad as the energy hub (issue 20): charging aMussels draws on its battery, and when the next
trip would not be covered it goes home to its charger, charges (the SITL says CHARGING over MAVLink,
the GCS hears it) and comes back to work. The real lockstep loop over real MAVLink bytes."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import pytest

from gcs.mission.headless import run_mission
from gcs.scenario.reader import MISSIONS_DIR, scenario_from_data

pytestmark = [pytest.mark.sitl]


def test_the_apad_goes_home_to_charge_and_comes_back_to_work(tmp_path: Path) -> None:
    path = MISSIONS_DIR / "pool12.toml"
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    # A small battery and a strong charger, so a 20-minute mission needs the charger once.
    data["apad"].update(battery_wh=40.0, home_charge_w=200.0)
    data["mission"]["duration"] = "20m"
    result = run_mission(scenario_from_data(path, data), tmp_path / "run")
    events = [json.loads(line) for line in (tmp_path / "run" / "events.jsonl").read_text().splitlines()]
    kinds = [e["event"] for e in events]
    went, back = kinds.index("home_charge"), kinds.index("home_charged")
    assert went < back and events[back]["charging_heard"]  # the GCS heard BATTERY_STATUS say CHARGING
    assert events[back]["battery_v"] > events[went]["battery_v"] + 1.0
    assert "docked" in kinds[back:]  # back to work: aMussels collected after the charge
    (row,) = result.apads
    assert row["home_charges"] >= 1 and row["home_wh"] > 0
    assert row["passed_wh"] > 0 and row["drawn_wh"] == pytest.approx(row["passed_wh"] / 0.6, rel=1e-3)
    assert result.end_reason == "mission time"  # the battery never ran out


def test_a_charger_that_never_charges_ends_the_wait_at_its_bound_and_the_mission_goes_on(tmp_path: Path) -> None:
    """The same small battery, its home charger dead (0 W): the check sends it home, nothing charges, the
    wait ends at its bound (`home_charge_failed`) and the mission goes on."""
    path = MISSIONS_DIR / "pool12.toml"
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    data["apad"].update(battery_wh=40.0, home_charge_w=0.0)
    data["mission"]["duration"] = "20m"
    result = run_mission(scenario_from_data(path, data), tmp_path / "run")
    kinds = [json.loads(line)["event"] for line in (tmp_path / "run" / "events.jsonl").read_text().splitlines()]
    assert "home_charge" in kinds and "home_charge_failed" in kinds and "home_charged" not in kinds
    assert result.apads[0]["home_wh"] == 0.0
