"""keep_alive keeps a small fleet alive where cautious does not (issue 20): four always-on aMussels, one
aPad whose small battery sends it home to a slow charger for half an hour, longer than an always-on
aMussel's remaining charge. cautious leaves them on; keep_alive orders them to sleep before it goes
(AMUSSEL_SLEEP_ORDER: in the GCS's .tlog, and applied by the fleet), so none depletes. The real lockstep
loop over real MAVLink bytes."""

from __future__ import annotations

from pathlib import Path

import pytest
from testkit import read_jsonl, scenario_variant

from gcs.mission.headless import run_mission
from gcs.scenario.reader import load_scenario
from mavlink_dialect import subcultron as mavlink
from mavlink_dialect.tlog import frames

pytestmark = pytest.mark.sitl


def small_fleet(tmp_path: Path, strategy: str) -> Path:
    return scenario_variant("bay-capacity", tmp_path / f"{strategy}.toml", {
        "count = 8": "count = 4",
        'duration = "40m"': 'duration = "60m"',
        'collect_strategy = "greedy"': f'collect_strategy = "{strategy}"',
        "battery_end_v = 11.0": "battery_end_v = 11.0\nbattery_wh = 30.0\nhome_charge_w = 80.0",
    })


def sleep_orders_on_the_wire(tlog: Path) -> list[tuple[int, float, float]]:
    """(aMussel, interval, awake) of every AMUSSEL_SLEEP_ORDER the GCS sent, parsed from its .tlog."""
    codec = mavlink.MAVLink(None)
    found = []
    for _, frame in frames(tlog):
        for msg in codec.parse_buffer(frame) or []:
            if msg.get_msgId() == mavlink.MAVLINK_MSG_ID_AMUSSEL_SLEEP_ORDER:
                found.append((msg.mussel_id, msg.interval, msg.awake))
    return found


def test_keep_alive_puts_the_fleet_to_sleep_before_a_home_charge_and_loses_none(tmp_path: Path) -> None:
    cautious = run_mission(load_scenario(small_fleet(tmp_path, "cautious")), tmp_path / "cautious")
    kept = run_mission(load_scenario(small_fleet(tmp_path, "keep_alive")), tmp_path / "keep_alive")
    for result in (cautious, kept):
        assert result.apads[0]["home_charges"] >= 1  # both went home for the charger
    assert any(m["state_s"]["depleted"] > 0 for m in cautious.to_json()["mussels"])
    assert all(m["state_s"]["depleted"] == 0 for m in kept.to_json()["mussels"])
    assert kept.uptime["min"] > cautious.uptime["min"]

    events = read_jsonl(tmp_path / "keep_alive" / "events.jsonl")
    home = next(e["t_s"] for e in events if e["event"] == "home_charge")
    slept = {e["mussel"] for e in events if e["event"] == "sleep_order" and e["why"] == "home charge"}
    assert slept == {1, 2, 3, 4} and all(e["t_s"] == home for e in events if e.get("why") == "home charge")
    wire = sleep_orders_on_the_wire(tmp_path / "keep_alive" / "gcs.tlog")
    assert {(m, 3600.0, 10.0) for m in slept} <= set(wire)
    mussels = kept.to_json()["mussels"]
    assert all(m["profile"].startswith("always_on+order:") for m in mussels)  # the fleet applied them
    assert sum(m["samples_scheduled"] for m in mussels) > 0  # asleep, each wake is a sample scheduled
    assert sleep_orders_on_the_wire(tmp_path / "cautious" / "gcs.tlog") == []


def test_a_fleet_smaller_than_min_pool_is_collected(tmp_path: Path) -> None:
    """Two aMussels and min_pool 4: the loop waited for four candidates that could never be, and both
    depleted uncollected (the capacity study's smallest fleet). It waits for the aMussels it has."""
    path = scenario_variant("bay-capacity", tmp_path / "two.toml", {
        "count = 8": "count = 2", 'duration = "40m"': 'duration = "8m"', "start_battery = [0.6, 1.0]":
        "start_battery = [0.6, 0.7]", 'collect_strategy = "greedy"': 'collect_strategy = "cautious"'})
    result = run_mission(load_scenario(path), tmp_path / "run").to_json()
    assert sorted(m["id"] for m in result["mussels"] if m["dockings"]) == [1, 2]
