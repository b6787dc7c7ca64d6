"""Sleeping aMussels in the lockstep world (SITL aPad, fleet and GCS over real MAVLink bytes): a sleep
order from the aPad API changes the aMussel's discharge and quiets its status, a call-up is taken at its
wake, and a mission of sleeping aMussels collects them and counts their samples."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest
from testkit import read_jsonl, scenario_variant

from gcs.mission.headless import run_mission
from gcs.mission.world import headless_world
from gcs.scenario.reader import load_scenario
from mussel_sim.battery import DISCHARGE_ACTIVE_PER_MIN
from mussel_sim.behaviour import duty_cycle_rate_per_min
from mussel_sim.report_policy import STATUS_KEEPALIVE_S
from mussel_sim.vocabulary import MusselCommand, MusselState
from mussel_sim.wake import next_wake_s

pytestmark = pytest.mark.sitl


def test_a_sleep_order_from_the_api_changes_discharge_and_status_and_holds_a_call_up() -> None:
    world = headless_world(load_scenario("pool12"))
    try:
        api, clock, fleet = world.api, world.clock, world.fleet
        api.wait_apad(timeout_s=10.0)
        sleeper, awake = 6, 7
        with pytest.raises(ValueError, match="awake_over_interval"):
            api.sleep_order(sleeper, 60.0, 600.0)  # refused before it is sent
        api.sleep_order(sleeper, 3600.0, 10.0)
        clock.sleep(1.0)
        k, j = (int(fleet.state.index_of([m])[0][0]) for m in (sleeper, awake))
        assert fleet.state.profiles.profiles[fleet.state.profile[k]].name == "always_on+order:3600s/10s"
        u0 = fleet.state.battery_frac.copy()
        clock.sleep(130.0)  # 65 simulated minutes: a wake in them
        drop = u0 - fleet.state.battery_frac
        assert drop[k] == pytest.approx(duty_cycle_rate_per_min(3600.0, 10.0) * 65, rel=1e-6)  # 14,057-min rate
        assert drop[j] == pytest.approx(DISCHARGE_ACTIVE_PER_MIN * 65, rel=1e-6)
        # The GCS hears it only in a second after one of its wakes (every 120 s here); the others, whose
        # state does not change, at each keep-alive window's start (`report_policy`).
        heard_s = api.mussels[sleeper].time_us / 1e6
        assert clock.time() - STATUS_KEEPALIVE_S < api.mussels[awake].time_us / 1e6 <= clock.time()
        assert api.mussels[awake].time_us % round(STATUS_KEEPALIVE_S * 1e6) == 0
        assert heard_s > 0.0 and next_wake_s(sleeper, 3600.0, 10.0, heard_s - 1.0, 30.0) <= heard_s
        # Not since: asleep (heard in the awake window's step; it reports once a wake, the state unchanged).
        assert next_wake_s(sleeper, 3600.0, 10.0, heard_s + 1.0, 30.0) > clock.time()
        # A call-up is held till its wake, computed by the GCS from what it ordered: then it rises.
        t_call = clock.time()
        t_w = next_wake_s(sleeper, 3600.0, 10.0, t_call, 30.0)
        assert t_w > t_call + 2.0, "pick a time it sleeps"
        api.command_mussel(sleeper, MusselCommand.SURFACE)
        clock.sleep(t_w - t_call - 1.0)
        assert fleet.state.state[k] == MusselState.ACTIVE and fleet.state.surface_held[k]
        clock.sleep(2.0)
        assert fleet.state.state[k] == MusselState.SURFACING
        api.command_mussel(sleeper, MusselCommand.SINK)  # nothing lost: it goes down again once afloat
        assert fleet.dropped == {}
    finally:
        world.close()


def test_a_mission_of_sleeping_amussels_collects_them_at_their_wakes_and_counts_samples(tmp_path: Path) -> None:
    path = scenario_variant("pool12", tmp_path / "pool12-sleep.toml", {"[fleet]": '[fleet]\nprofile = "hourly_wake"'})
    scenario = load_scenario(path)
    scenario = replace(scenario, mission=replace(scenario.mission, duration_s=480.0))
    result = run_mission(scenario, tmp_path / "run")
    events = read_jsonl(tmp_path / "run" / "events.jsonl")
    skipped = [e for e in events if e.get("event") == "skip" and e.get("why") == "did not surface"]
    assert skipped == [], "a call-up to a sleeper waits for its wake (world.py: call_up_wait_s)"
    called = {e["mussel"]: e["t_s"] for e in events if e.get("event") == "call_up"}
    docked = {e["mussel"]: e["t_s"] for e in events if e.get("event") == "docked"}
    assert len(docked) >= 2
    for m, t_s in docked.items():  # each rose at its wake, not at the call-up
        assert t_s >= next_wake_s(m, 3600.0, 10.0, called[m], scenario.mission.theta) + scenario.fleet.surfacing_time_s
    assert {m.profile for m in result.mussels} == {"hourly_wake"}
    for m in result.mussels:
        assert m.samples_scheduled == 4  # 8 minutes at theta 30: four simulated hours, a wake in each
        if m.dockings:
            assert m.samples_taken < m.samples_scheduled and m.uptime_pct < 100.0  # docked at a wake: missed
        else:
            assert m.samples_taken == m.samples_scheduled and m.uptime_pct == 100.0  # asleep on the seabed: up
    assert all(w["where"] in ("seabed", "slot") for w in result.whereabouts)
