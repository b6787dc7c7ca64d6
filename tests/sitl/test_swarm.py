"""Several aPads sharing one fleet, in lockstep: embedded SITL aPads over real MAVLink bytes."""

from __future__ import annotations

import threading
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
from testkit import read_jsonl

from apad_sitl.vocabulary import Latch
from gcs.link.apad_api import Location
from gcs.link.telemetry import SlotView
from gcs.mission.headless import run_mission
from gcs.mission.world import LinkOptions, headless_world
from gcs.scenario.reader import load_scenario
from gcs.swarm.shares import FleetShares, SwarmWatch, route_conflicts
from missiontime import US_PER_S
from mussel_sim.comms import FLEET_SYSTEM_ID
from mussel_sim.vocabulary import MusselState

pytestmark = pytest.mark.sitl


def _call_ups_within_shares(events: list[dict[str, Any]]) -> None:
    """Every call-up is by an aPad of an aMussel in its share as last re-shared: never another's."""
    shares: dict[int, set[int]] = {}
    for e in events:
        if e["event"] == "reshare":
            shares = {int(a): set(ids) for a, ids in e["shares"].items()}
        elif e["event"] == "call_up":
            assert e["mussel"] in shares[e["apad"]], e


def test_two_apads_share_the_pool_fleet_and_each_serves_only_its_share(tmp_path: Path) -> None:
    s = load_scenario("pool12x2").with_overrides(duration_s=1200.0)
    r = run_mission(s, tmp_path)
    assert [a["sysid"] for a in r.apads] == [1, 2]
    share_1, share_2 = (set(a["mussels"]) for a in r.apads)
    assert share_1 | share_2 == set(range(1, 13)) and not share_1 & share_2
    assert all(a["dockings"] >= 4 and a["travelled_m"] > 10.0 for a in r.apads)  # both worked
    assert r.misplaced == [] and len(r.whereabouts) == 12
    # Each docking is by the aPad whose share the aMussel is in (nobody was lost, no re-share).
    for m in r.mussels:
        for d in m.dockings:
            assert m.id in (share_1 if d["apad"] == 1 else share_2)
    events = read_jsonl(tmp_path / "events.jsonl")
    assert [e["event"] for e in events].count("reshare") == 1
    _call_ups_within_shares(events)
    # Its own two SITL aPads, each with its own logs.
    assert (tmp_path / "apad1.tlog").stat().st_size > 0 and (tmp_path / "apad2.tlog").stat().st_size > 0
    # Lockstep stays deterministic with two loops taking turns on the clock.
    again = run_mission(s)
    assert (again.uptime, again.cost_m, again.apads) == (r.uptime, r.cost_m, r.apads)


def test_a_failed_apad_is_noticed_its_share_is_taken_over_and_nothing_is_lost(tmp_path: Path) -> None:
    s = load_scenario("pool12x2").with_overrides(duration_s=1500.0)
    r = run_mission(s, tmp_path, options=LinkOptions(fail_apads=((2, 300.0),)))
    events = read_jsonl(tmp_path / "events.jsonl")
    reshares = [e for e in events if e["event"] == "reshare"]
    assert len(reshares) == 2
    lost_at = reshares[1]["t_s"]
    assert reshares[1]["lost"] == [2] and 300.0 < lost_at <= 312.0  # silent for 10 s: lost
    assert reshares[1]["shares"] == {"1": list(range(1, 13))}  # the whole fleet is aPad 1's now
    was_2s = set(reshares[0]["shares"]["2"])
    taken_over = [(m.id, d["t_s"]) for m in r.mussels for d in m.dockings
                  if m.id in was_2s and d["apad"] == 1 and d["t_s"] > lost_at]
    assert taken_over, "aPad 1 never docked an aMussel of aPad 2's share after it was lost"
    assert not [d for m in r.mussels for d in m.dockings if d["apad"] == 2 and d["t_s"] > 300.0]
    _call_ups_within_shares(events)
    # Nothing lost: what aPad 2 held when it went silent is reported held on it, the rest is home.
    assert r.misplaced == [] and len(r.whereabouts) == 12
    held = [w for w in r.whereabouts if w["where"] == "slot" and "aPad 2" in w["detail"]]
    assert held and all(w["id"] in was_2s for w in held)  # it was mid-cycle at 300 s
    assert r.apads[1]["mussels"] == sorted(was_2s) and r.apads[1]["share_at_end"] == []


def test_an_apad_whose_loop_ended_is_retired_and_its_share_goes_to_the_others() -> None:
    world = headless_world(load_scenario("pool12x2"))
    try:
        for sysid in (1, 2):
            world.api.wait_apad(timeout_s=10.0, apad_id=sysid)
        shares = FleetShares()
        watch = SwarmWatch(world.link.registry, shares, world.frame, {1: 11.0, 2: 11.0}, world.events, world.clock)
        watch.check(world.clock.now_us)
        assert shares.usable == {1, 2} and len(shares.owner) == 12
        watch.retire(2)  # e.g. its battery ended its loop; it is still heard, with volts to spare now
        world.clock.sleep(5.0)
        watch.check(world.clock.now_us)
        assert shares.usable == {1} and set(shares.owner.values()) == {1}
    finally:
        world.close()


def test_a_leg_passing_another_apad_is_a_conflict_and_one_clear_of_it_is_not() -> None:
    world = headless_world(load_scenario("pool12x2"))
    try:
        for sysid in (1, 2):
            world.api.wait_apad(timeout_s=10.0, apad_id=sysid)
        one, two = world.api.position(1), world.api.position(2)
        beyond_two = Location(two.lat, two.lon + (two.lon - one.lon) * 0.2)  # past aPad 2, the leg runs over it
        beside_one = Location(one.lat + 4e-5, one.lon)  # ~4.4 m north of aPad 1, away from aPad 2
        assert route_conflicts(world.api, 1, beyond_two, separation_m=3.0) == [2]
        assert route_conflicts(world.api, 1, beside_one, separation_m=3.0) == []
        # Where aPad 2 is going counts too: send it next to aPad 1's short leg.
        world.api.go_to(Location(one.lat + 2e-5, one.lon + 1e-5), apad_id=2)
        world.clock.sleep(0.5)
        assert route_conflicts(world.api, 1, beside_one, separation_m=3.0) == [2]
    finally:
        world.close()


def test_each_apad_waits_for_its_shares_part_of_the_pool_not_the_whole_fleets() -> None:
    """docs/strategies.md, pool12x2: with min_pool 4 of a fleet of 12, an aPad with a share of 6 waits
    for 2 candidates (it waited for 4 of its 6 and set off late); one aPad waits for 4 as ever."""
    world = headless_world(load_scenario("pool12x2"))
    try:
        shares = FleetShares(owner={m: 1 if m <= 6 else 2 for m in range(1, 13)})
        assert world.mission_loop(apad_id=1, shares=shares).knows.pool_needed(4) == 2
        shares.owner = {m: 1 if m == 1 else 2 for m in range(1, 13)}  # a share of one
        assert world.mission_loop(apad_id=1, shares=shares).knows.pool_needed(4) == 1
        assert world.mission_loop(apad_id=2, shares=shares).knows.pool_needed(4) == 4  # ceil(4 x 11 / 12)
        assert world.mission_loop(apad_id=1).knows.pool_needed(4) == 4  # alone: the scenario's min_pool
    finally:
        world.close()


def test_an_amussel_docked_on_another_apad_is_believed_charging_until_a_slot_lets_it_go() -> None:
    """The GCS runs a docked aMussel's last report forward charging (`foresight`) until an aPad says a slot
    let go of it: also when the slot is another aPad's (aPad 1 believed one on aPad 2's slot draining)."""
    world = headless_world(load_scenario("pool12x2"))
    try:
        for sysid in (1, 2):
            world.api.wait_apad(timeout_s=10.0, apad_id=sysid)
        knows = world.mission_loop(apad_id=1).knows
        registry, now = world.link.registry, world.clock.now_us
        mussel = 7
        assert mussel not in knows.docked().values()
        # Its report of 30 s ago, docked (as the fleet sends it), at half charge.
        registry.apply(FLEET_SYSTEM_ID, replace(world.api.mussels[mussel], state=MusselState.DOCKED,
                                                battery_frac=0.5, time_us=now - 30 * US_PER_S), now)
        charging = knows.battery(mussel)
        assert charging > 0.5  # 30 steps of charging on aPad 2's slot
        # aPad 2 says its slot 2 held it and, 20 s ago, let it go: charged 10 s, drained 20 s since.
        registry.apply(2, SlotView(2, mussel, Latch.LATCHED), now - 25 * US_PER_S)
        registry.apply(2, SlotView(2, 0, Latch.OPEN), now - 20 * US_PER_S)
        released = knows.battery(mussel)
        assert 0.5 < released < charging
        # A release before its last report is an older docking's: charging again.
        registry.apply(FLEET_SYSTEM_ID, replace(world.api.mussels[mussel], time_us=now - 10 * US_PER_S), now)
        assert knows.battery(mussel) > released
    finally:
        world.close()


def test_each_loop_commands_only_its_own_apad(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every command a swarm's loop sends goes to its own aPad. A loop's `hold` (idle and charging waits, home)
    used to go to the API's default aPad, 1: aPad 2 waiting for its aMussels to charge stopped aPad 1 mid
    Go To, which then sent its Go To again ("goto_resent", 25 times in bay120 keep_alive seed 1)."""
    from gcs.link.command_protocol import CommandClient

    sent: list[tuple[str, int]] = []
    for name in ("send_long", "send_int"):
        original = getattr(CommandClient, name)

        def spy(self: CommandClient, target: int, *args: Any, _original: Any = original, **kwargs: Any) -> Any:
            sent.append((threading.current_thread().name, target))
            return _original(self, target, *args, **kwargs)

        monkeypatch.setattr(CommandClient, name, spy)
    r = run_mission(load_scenario("pool12x2").with_overrides(duration_s=900.0))
    assert all(a["dockings"] >= 2 for a in r.apads)  # both loops worked: docked, charged, held
    by_loop = {(thread, target) for thread, target in sent if thread.startswith("process-apad")}
    assert {thread for thread, _ in by_loop} == {"process-apad1", "process-apad2"}
    assert by_loop == {(f"process-apad{target}", target) for _, target in by_loop}
