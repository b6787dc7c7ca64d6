"""A rolling aPad goes home to charge (found by the capacity study, issue 38): it always carries an aMussel
or two, and the rounds' check is made with nothing on board, so a rolling aPad worked until its battery
ended the mission (bay-capacity, 60 hourly-wake aMussels: "aPad battery" at 2.2 h of 24). Now, when the
battery would no longer cover putting everyone on board back and the way home, it puts them all back and
goes home. The real lockstep loop over real MAVLink bytes, with a small battery that needs the charger
within the hour."""

from __future__ import annotations

from pathlib import Path

import pytest
from testkit import read_jsonl, scenario_variant

from gcs.mission.headless import run_mission
from gcs.scenario.reader import load_scenario

pytestmark = pytest.mark.sitl


def test_a_rolling_apad_puts_back_what_it_carries_and_goes_home_to_charge(tmp_path: Path) -> None:
    path = scenario_variant("bay-capacity", tmp_path / "rolling.toml", {
        'duration = "40m"': 'duration = "60m"',
        'collect_strategy = "greedy"': 'collect_strategy = "rolling"',
        "battery_end_v = 11.0": "battery_end_v = 11.0\nbattery_wh = 30.0\nhome_charge_w = 80.0",
    })
    result = run_mission(load_scenario(path), tmp_path / "run")
    assert result.end_reason == "mission time"  # not "aPad battery": it charged before running flat
    assert result.apads[0]["home_charges"] >= 1

    # Every time it set off home it carried nobody: each aMussel docked was let go first.
    on_board: set[int] = set()
    homes = 0
    for e in read_jsonl(tmp_path / "run" / "events.jsonl"):
        if e["event"] == "docked":
            on_board.add(e["mussel"])
        elif e["event"] == "released":
            on_board.discard(e["mussel"])
        elif e["event"] == "home_first":  # the battery called it home loaded: those are put back at once
            assert set(e["on_board"]) == on_board and on_board
        elif e["event"] == "home_charge":
            homes += 1
            assert not on_board, (e["t_s"], on_board)
    assert homes >= 1
