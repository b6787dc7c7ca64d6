"""The loop's phases alone: each on a recording crew over a scripted world (`loop_bench`), no SITL, no MAVLink.

A test sets the world (the fleet as the GCS knows it, the aPad's slots, position and battery), runs one phase,
and reads back the commands and waits it made, in order, and the events it logged; pool12's settings.
"""

from __future__ import annotations

import inspect
from typing import cast

import pytest
from loop_bench import Bench, Call, RecordingActions, public_names, same_signature
from loop_world import ScriptedKnowledge
from wake_reference import same_instant, scalar_pool_look_by

from apad_sitl.vocabulary import Latch
from gcs.link.telemetry import SlotView
from gcs.loop import phases, turns, wake_times
from gcs.loop.actions import ApadActions
from gcs.loop.control import MissionEnded, Phase
from gcs.loop.fleet_knowledge import FleetKnowledge
from gcs.loop.home_charge import NOT_CHARGING_S, go_home_and_charge, within_energy
from gcs.loop.sleep_orders import ALWAYS_ON, ASLEEP, reschedule
from gcs.loop.trip_energy import needs_home
from gcs.strategies import STRATEGIES, PlanInput
from gcs.swarm.shares import FleetShares
from mussel_sim.vocabulary import MusselState

ACTIVE, FLOATING, SURFACING, DOCKED, DEPLETED, SINKING = (
    MusselState.ACTIVE, MusselState.FLOATING, MusselState.SURFACING, MusselState.DOCKED, MusselState.DEPLETED,
    MusselState.SINKING)
FULL_V, LOW_V = 15.9, 11.4  # the aPad's battery: charged (>= 95 %), and just above its reserve


@pytest.fixture
def b() -> Bench:
    return Bench()


def pool_of(b: Bench, batteries: list[float]) -> None:
    """aMussels 1.. on the seabed in a row 10 m apart, 5 m north of the aPad's home."""
    for m, battery in enumerate(batteries, start=1):
        b.mussel(m, 10.0 * m, 5.0, battery)


def phases_set(b: Bench) -> list[Phase]:
    return [args[0] for args in b.act.args("set_phase")]


# --- the fakes ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("real", "fake", "own"), [
    (FleetKnowledge, ScriptedKnowledge, {"world"}),
    (ApadActions, RecordingActions, {"calls", "failing", "changes", "rising", "fail", "then", "names", "args"}),
])
def test_the_fakes_have_the_real_public_names_and_signatures(real: type, fake: type, own: set[str]) -> None:
    # `api` (and the actions' `pace`) are left out on purpose: a phase reaching them fails on the bench.
    assert public_names(real) - {"api", "pace"} == public_names(fake) - own
    for name in public_names(real) - {"api", "pace"}:
        theirs = inspect.getattr_static(real, name, None)
        if inspect.isfunction(theirs):
            assert same_signature(theirs, getattr(fake, name)), name


# --- collection --------------------------------------------------------------------------------------------


def test_idle_wait_holds_until_the_pool_holds_min_pool_candidates(b: Bench) -> None:
    pool_of(b, [0.5, 0.6, 0.9, 0.9, 0.9, 0.9])  # two below 0.80 of six on the seabed: min_pool is 4
    b.act.then(lambda: b.world.batteries.update({3: 0.7, 4: 0.7}))
    phases.idle_wait(b.crew)
    assert b.act.calls == [Call("set_phase", (Phase.IDLE_WAIT,)), Call("hold"), Call("wait_until", (None, True, 0.0))]
    assert b.status.phase == Phase.IDLE_WAIT
    assert b.logged("phase") == [("phase", {"phase": "idle wait"})]


def test_idle_wait_with_too_few_candidates_waits_to_the_mission_end(b: Bench) -> None:
    pool_of(b, [0.5, 0.6, 0.9, 0.9, 0.9, 0.9])
    with pytest.raises(MissionEnded):
        phases.idle_wait(b.crew)


def test_idle_wait_ends_for_an_orphan_to_fetch_with_the_pool_empty(b: Bench) -> None:
    pool_of(b, [0.9, 0.9, 0.9, 0.9])
    b.mussel(9, 15.0, 0.0, 0.9, FLOATING)
    b.world.orphans = [9]
    phases.idle_wait(b.crew)
    assert b.act.names() == ["set_phase", "hold", "wait_until"]


def test_idle_wait_with_the_strategy_none_never_collects(b: Bench) -> None:
    pool_of(b, [0.1, 0.1, 0.1, 0.1])
    b.status.strategy = "none"
    with pytest.raises(MissionEnded):
        phases.idle_wait(b.crew)


def test_the_idle_waits_wake_time_is_the_per_amussel_formulas_on_the_bench() -> None:
    """`pool_look_by` over the fleet's beliefs at once gives the instant the scalar reads gave, to the bit: batteries
    above, at and below the threshold (those below: none), sleepers on the scenario's profile and on an order,
    one docked and one floating (not on the seabed: left out), a lost aPad's claims lapsing; at many instants."""
    b = Bench("bay120-sleep")
    pool_of(b, [0.95, 0.80, 0.8000001, 0.5, 0.99, 1.0, 0.0, 0.87])
    b.mussel(20, 5.0, 5.0, 0.9, state=FLOATING)
    b.on_slot(1, 21, battery=0.3)
    b.book.ordered(2, ASLEEP)
    b.book.ordered(5, ALWAYS_ON)
    b.world.shares = FleetShares(owner={m: 1 for m in range(1, 22)}, lost_since_us={2: 40_000_000, 3: 9_000_000})
    looked = []
    for step in range(30):
        b.clock.advance_to(b.clock.now_us + 7_300_000 * step)
        b.world.batteries[8] = max(b.world.batteries[8] - 0.004, 0.0)
        got = wake_times.pool_look_by(cast(FleetKnowledge, b.knows))
        assert same_instant(got, scalar_pool_look_by(cast(FleetKnowledge, b.knows))), step
        looked.append(got)
    assert None not in looked and len(set(looked)) > 10  # an instant ahead each time, and it moves


def test_plan_collection_puts_orphans_first_and_leaves_out_the_unreachable(b: Bench) -> None:
    pool_of(b, [0.7, 0.3, 0.5, 0.2, 0.6, 0.75])
    b.world.outside = {4}  # the lowest: carried outside the geofence
    b.mussel(9, 15.0, 0.0, 0.9, FLOATING)
    b.world.orphans = [9]
    route = phases.plan_collection(b.crew)
    assert route == [9, 2, 3, 5]  # the orphan, then cautious's lowest batteries for the 3 slots left
    assert b.status.route == route
    assert b.act.calls == [Call("set_phase", (Phase.PLAN_COLLECT,))]
    where = b.world.locations[4]
    assert b.logged() == [
        ("unreachable", {"mussel": 4, "lat": where.lat, "lon": where.lon, "why": "outside the geofence"}),
        ("plan_collection", {"strategy": "cautious", "route": route, "orphans": [9]}),
    ]
    phases.plan_collection(b.crew)  # found out of reach once: logged once
    assert b.kinds().count("unreachable") == 1


def test_a_strategy_that_raises_is_logged_and_cautious_plans_the_step(b: Bench, monkeypatch: pytest.MonkeyPatch,
                                                                     ) -> None:
    def broken(inp: PlanInput, weights: object) -> dict[int, list[int]]:
        raise RuntimeError("no plan today")

    monkeypatch.setitem(STRATEGIES, "broken", broken)
    pool_of(b, [0.7, 0.3, 0.5, 0.2])
    b.status.strategy = "broken"
    assert phases.plan_collection(b.crew) == [4, 2, 3, 1]
    assert b.logged("strategy_failed") == [("strategy_failed", {
        "strategy": "broken", "why": "strategy broken raised RuntimeError: no plan today", "instead": "cautious",
        "failures": 1})]
    # The plan is labelled with the strategy that made it, and the one that failed.
    assert b.logged("plan_collection") == [("plan_collection", {"strategy": "cautious", "route": [4, 2, 3, 1],
                                                                "failed": "broken"})]


COLLECT_ONE = ["set_phase", "check_end", "wait_for_link", "call_up_if_in_range", "go_to", "wait_until"]


def test_collect_calls_up_goes_to_and_docks_on_the_first_free_slot(b: Bench) -> None:
    where = b.mussel(3, 10.0, 0.0, 0.3)
    b.world.slots[1] = SlotView(1, 12, Latch.LATCHED)  # slot 1 taken
    phases.collect(b.crew, [3])
    assert b.act.calls == [
        Call("set_phase", (Phase.COLLECT,)), Call("check_end"), Call("wait_for_link", (None, True)),
        Call("call_up_if_in_range", (3,)),
        Call("go_to", (where, False)),  # called up: the mission end no longer interrupts it
        Call("wait_until", (b.settings.surfacing_timeout_s, False, b.settings.mussel_surfacing_s)),
        Call("dock", (2, 3)),
    ]
    assert b.kinds() == ["call_up", "docked"]
    assert b.logged("docked") == [("docked", {"mussel": 3, "slot": 2})]
    assert b.status.dockings == [(0.0, 3)]
    assert b.status.target_mussel == 0
    assert b.world.states[3] == DOCKED


def test_collect_closes_in_on_one_that_surfaced_away_from_where_it_was(b: Bench) -> None:
    where = b.mussel(3, 10.0, 0.0, 0.3)
    drifted = b.at(13.0, 0.0)  # 3 m off: more than 0.8 of the 2-m docking reach
    b.act.then(lambda: b.world.locations.update({3: drifted}))
    phases.collect(b.crew, [3])
    assert b.act.args("go_to") == [(where, False), (drifted, False)]
    assert b.act.names()[-1] == "dock"


def test_collect_sinks_one_whose_dock_failed(b: Bench) -> None:
    b.mussel(3, 10.0, 0.0, 0.3)
    b.act.fail("dock", 3)
    phases.collect(b.crew, [3])
    assert b.act.names() == [*COLLECT_ONE, "dock", "dock", "sink"]  # still floating beside it: once more
    assert b.logged("skip") == [("skip", {"mussel": 3, "why": "docking failed"})]
    assert b.logged("failed_docking") == [("failed_docking", {"mussel": 3, "outcome": "back on its position",
                                                               "off_m": 0.0})]
    assert b.status.dockings == []
    assert b.world.states[3] == SINKING


def test_a_failed_dock_whose_sink_goes_unanswered_is_reported_at_the_surface_not_on_its_position(b: Bench) -> None:
    b.mussel(3, 10.0, 0.0, 0.3)
    b.act.fail("dock", 3)
    b.act.fail("sink", 3)
    phases.collect(b.crew, [3])
    assert b.logged("failed_docking") == [("failed_docking", {
        "mussel": 3, "outcome": "left at the surface", "off_m": 0.0, "why": "it did not answer the sink command"})]
    assert b.status.off_position == {3: "docking failed at 0 s, it did not answer the sink command"}


def test_collect_sends_down_one_that_did_not_surface_and_goes_on(b: Bench) -> None:
    b.mussel(3, 10.0, 0.0, 0.3)
    b.mussel(4, 20.0, 0.0, 0.3)
    b.world.rises_to[3] = ACTIVE  # called up, still on the seabed when the wait ends
    phases.collect(b.crew, [3, 4])
    assert b.act.names() == [*COLLECT_ONE, "sink", *COLLECT_ONE[1:], "dock"]
    assert b.logged("skip") == [("skip", {"mussel": 3, "why": "did not surface", "state": "ACTIVE"})]
    assert b.act.args("sink") == [(3,)]
    assert b.logged("docked") == [("docked", {"mussel": 4, "slot": 1})]


@pytest.mark.parametrize(("at_surface", "why"), [(True, "depleted at the surface"),
                                                 (False, "depleted before it floated")])
def test_collect_releases_one_depleted_as_it_rose(b: Bench, at_surface: bool, why: str) -> None:
    b.world.shares = FleetShares(owner={3: 1})
    b.mussel(3, 10.0, 0.0, 0.3)
    b.world.rises_to[3] = DEPLETED
    if at_surface:
        b.act.then(lambda: b.world.surfaced.add(3))
    phases.collect(b.crew, [3])
    assert b.act.names() == COLLECT_ONE  # no dock, no sink: it cannot move now
    assert b.logged("skipped") == [("skipped", {"mussel": 3, "why": why})]
    assert b.world.shares.claims == {}  # claimed for the call-up, released


def test_collect_sinks_one_called_up_whose_position_cannot_be_reached(b: Bench) -> None:
    where = b.mussel(3, 10.0, 0.0, 0.3)
    b.act.fail("go_to", where)
    phases.collect(b.crew, [3])
    assert b.act.names() == [*COLLECT_ONE[:-1], "sink"]


def test_collect_stops_calling_up_near_the_mission_end(b: Bench) -> None:
    b.mussel(3, 10.0, 0.0, 0.3)
    b.clock.sleep(b.settings.mission.duration_s - b.settings.call_up_margin_s + 1.0)
    phases.collect(b.crew, [3])
    assert b.act.names() == ["set_phase", "check_end", "wait_for_link"]
    assert b.logged("skip") == [("skip", {"mussel": 3, "why": "too close to the mission end to dock it"})]


@pytest.mark.parametrize("when", ["did not surface", "surfaced", "closing in"])
def test_collect_leaves_one_another_aapad_took_over_while_it_rose(b: Bench, when: str) -> None:
    shares = b.world.shares = FleetShares(owner={3: 1})
    b.mussel(3, 10.0, 0.0, 0.3)
    if when == "did not surface":
        b.world.rises_to[3] = ACTIVE

    def taken() -> None:
        shares.claims[3] = 2

    def drifted() -> None:  # 3 m off where it was called up: it would be closed in on
        b.world.locations[3] = b.at(13.0, 0.0)

    if when == "closing in":
        b.act.then(drifted)
        b.act.then(taken, at="go_to")
    else:
        b.act.then(lambda: (drifted(), taken()))
    phases.collect(b.crew, [3])
    # Neither docked nor sent down: the other aPad fetches it.
    assert b.act.names() == COLLECT_ONE + (["go_to"] if when == "closing in" else [])
    assert b.logged("skip") == [("skip", {"mussel": 3, "why": "taken over by another aPad while this one was "
                                                          "unheard"})]


def test_recheck_route_drops_a_depleted_one_and_replans_the_rest_floating_first(b: Bench) -> None:
    b.mussel(3, 30.0, 0.0, 0.3)
    b.mussel(4, 20.0, 0.0, 0.0, DEPLETED)
    b.mussel(5, 40.0, 0.0, 0.6, FLOATING)
    route = phases.recheck_route(b.crew, [3, 4, 5])
    assert route == [5, 3]
    assert b.status.route == [5, 3]
    assert b.logged() == [("skipped", {"mussel": 4, "why": "depleted"}),
                          ("replan_collection", {"strategy": "cautious", "route": [5, 3]})]
    assert b.act.calls == []


def test_recheck_route_keeps_a_route_that_can_still_be_collected(b: Bench) -> None:
    pool_of(b, [0.3, 0.2])
    route = [2, 1]
    assert phases.recheck_route(b.crew, route) is route
    assert b.logged() == []


def test_collect_rechecks_before_each_leg(b: Bench) -> None:
    b.mussel(3, 10.0, 0.0, 0.3)
    b.mussel(4, 20.0, 0.0, 0.3)
    b.act.then(lambda: b.world.states.update({4: DEPLETED}))  # while the aPad waits for 3 to float
    phases.collect(b.crew, [3, 4])
    assert b.act.names() == [*COLLECT_ONE, "dock", "check_end", "wait_for_link"]
    assert b.logged("skipped", "replan_collection") == [
        ("skipped", {"mussel": 4, "why": "depleted"}), ("replan_collection", {"strategy": "cautious", "route": []})]


def test_take_strategy_switch_takes_the_operators_strategy_once(b: Bench) -> None:
    b.control.strategy = "greedy"
    phases.take_strategy_switch(b.crew)
    assert (b.status.strategy, b.control.strategy) == ("greedy", None)
    assert b.logged() == [("strategy_switch", {"old": "cautious", "new": "greedy"})]
    b.control.strategy = "greedy"  # the same again: nothing to switch
    phases.take_strategy_switch(b.crew)
    assert len(b.logged()) == 1
    assert b.act.calls == []


# --- charging and redeployment ------------------------------------------------------------------------------


def test_charging_wait_holds_until_everything_on_board_is_charged(b: Bench) -> None:
    b.on_slot(1, 7, battery=0.995)
    b.on_slot(2, 8, battery=0.90)
    b.act.then(lambda: b.world.batteries.update({8: 0.99}))
    phases.charging_wait(b.crew)
    assert b.act.calls == [Call("set_phase", (Phase.CHARGING_WAIT,)), Call("hold"),
                           Call("wait_until", (None, True, 0.0))]


def test_charging_wait_with_one_short_of_charged_waits_on(b: Bench) -> None:
    b.on_slot(1, 7, battery=0.995)
    b.on_slot(2, 8, battery=0.98)
    with pytest.raises(MissionEnded):
        phases.charging_wait(b.crew)


def test_plan_redeployment_takes_them_home_nearest_first(b: Bench) -> None:
    b.on_slot(1, 7, home=b.at(30.0, 0.0))
    b.on_slot(2, 8, home=b.at(5.0, 0.0))
    b.on_slot(4, 9)  # no home known (held since a crash): back to where the aPad is now
    route = phases.plan_redeployment(b.crew)
    assert route == [(4, 9), (2, 8), (1, 7)]
    assert b.world.homes[9] == b.world.position
    assert b.logged() == [("plan_redeployment", {"strategy": "greedy", "route": [9, 8, 7]})]
    assert b.act.calls == [Call("set_phase", (Phase.PLAN_REDEPLOY,))]
    assert phases.plan_redeployment(b.crew, only={7}) == [(1, 7)]


def test_redeploy_takes_each_home_undocks_and_sends_it_down(b: Bench) -> None:
    home7, home8 = b.at(30.0, 0.0), b.at(5.0, 0.0)
    b.on_slot(1, 7, home=home7)
    b.on_slot(2, 8, home=home8)
    b.world.real = {7}  # over a radio: seen off the surface
    b.world.shares = FleetShares(owner={7: 1, 8: 1}, claims={7: 1, 8: 1})
    phases.redeploy(b.crew, [(2, 8), (1, 7)])
    leg = ["check_end", "wait_for_link", "go_to", "undock"]
    assert b.act.names() == ["set_phase", "begin_redeployment", *leg, "tell_to_sink", "let_go", *leg, "sink"]
    assert b.act.args("go_to") == [(home8, True), (home7, True)]
    assert b.act.args("undock") == [(2, 8), (1, 7)]
    assert b.logged() == [("released", {"mussel": 8, "slot": 2}), ("released", {"mussel": 7, "slot": 1})]
    assert b.act.leaving == {8}
    assert b.world.shares.claims == {}
    assert b.knows.docked() == {}


def test_redeploy_keeps_on_board_one_whose_position_cannot_be_reached(b: Bench) -> None:
    home7, home8 = b.at(30.0, 0.0), b.at(5.0, 0.0)
    b.on_slot(1, 7, home=home7)
    b.on_slot(2, 8, home=home8)
    b.act.fail("go_to", home8)
    phases.redeploy(b.crew, [(2, 8), (1, 7)])
    assert b.act.args("undock") == [(1, 7)]
    assert b.logged() == [
        ("kept_on_board", {"mussel": 8, "slot": 2, "why": "its position could not be reached"}),
        ("released", {"mussel": 7, "slot": 1}),
    ]
    assert b.knows.docked() == {2: 8}


def test_redeploy_releases_nothing_the_aapad_would_not_undock(b: Bench) -> None:
    b.on_slot(1, 7, home=b.at(30.0, 0.0))
    b.act.fail("undock", 7)
    phases.redeploy(b.crew, [(1, 7)])
    assert b.act.names()[-1] == "undock"
    assert b.logged() == []


# --- after a crash ------------------------------------------------------------------------------------------


def test_recover_sinks_what_floats_unclaimed_and_finishes_the_cycle_on_board(b: Bench) -> None:
    home7 = b.at(10.0, 0.0)
    b.world.shares = FleetShares(owner={5: 1, 6: 2, 7: 1})
    b.mussel(5, 20.0, 0.0, 0.5, FLOATING)
    b.mussel(6, 25.0, 0.0, 0.5, SURFACING)  # another aPad's: it may be latching it now
    b.on_slot(1, 7, battery=0.995, home=home7)
    phases.recover(b.crew)
    assert b.act.calls[:3] == [Call("sleep", (2.0, False)), Call("wait_until", (120.0, False, 0.0)), Call("sink", (5,))]
    assert phases_set(b) == [Phase.CHARGING_WAIT, Phase.PLAN_REDEPLOY, Phase.REDEPLOY]
    assert b.act.args("undock") == [(1, 7)]
    assert b.logged("recover") == [
        ("recover", {"mussel": 5, "action": "sink", "state": "FLOATING"}),
        ("recover", {"action": "finish charging cycle", "docked": [7]}),
    ]
    assert b.world.states[6] == SURFACING
    assert b.status.cycles == 1


def test_recover_gives_up_on_latches_that_stay_in_motion(b: Bench) -> None:
    b.world.slots[3] = SlotView(3, 4, Latch.CLOSING)
    phases.recover(b.crew)
    assert b.act.names() == ["sleep", "wait_until"]
    assert b.logged() == [("gave_up", {"what": "waiting for latches in motion", "slots": [3]})]


# --- the home charger ---------------------------------------------------------------------------------------


def test_within_energy_passes_a_route_the_battery_covers(b: Bench) -> None:
    pool_of(b, [0.3, 0.3])
    assert within_energy(b.crew, [1, 2]) == [1, 2]
    assert b.act.calls == []
    assert b.logged() == []


def test_within_energy_goes_home_to_charge_first_when_the_battery_is_low(b: Bench) -> None:
    pool_of(b, [0.3, 0.3])
    b.world.position = b.at(40.0, 0.0)
    b.world.battery_v = LOW_V

    def charged_at_home() -> None:
        b.clock.sleep(1800.0)
        b.world.charging_at_home, b.world.battery_v = True, FULL_V

    b.act.then(charged_at_home)
    assert within_energy(b.crew, [1, 2]) == []
    assert b.act.calls == [Call("set_phase", (Phase.HOME_CHARGE,)), Call("go_to", (b.home, True)), Call("hold"),
                           Call("slow_telemetry"), Call("wait_until", (None, True, 0.0))]
    (kind, started), (_, charged) = b.logged()
    assert (kind, started["battery_v"], started["route"]) == ("home_charge", LOW_V, [1, 2])
    assert started["trip_wh"] > 0
    assert charged == {"battery_v": FULL_V, "waited_s": 1800.0, "charging_heard": True}
    assert b.status.home_charges == 1


def test_within_energy_trims_a_route_no_charged_battery_covers(b: Bench) -> None:
    for m in range(1, 5):
        b.mussel(m, 600.0 * m, 0.0, 0.1)  # 2.4 km out and back, then home
    b.world.battery_v = FULL_V
    assert within_energy(b.crew, [1, 2, 3, 4]) == [1, 2, 3]
    assert b.logged() == [("route_trimmed", {"route": [1, 2, 3, 4], "kept": [1, 2, 3],
                                             "why": "more than a charged battery covers"})]
    assert b.act.calls == []
    assert not needs_home(b.crew.knows, [1, 2, 3])


def test_go_home_and_charge_at_a_charger_that_does_not_charge(b: Bench) -> None:
    b.world.battery_v = LOW_V
    b.act.then(lambda: b.clock.sleep(NOT_CHARGING_S))
    go_home_and_charge(b.crew, [])
    assert b.logged("home_charge_failed") == [
        ("home_charge_failed", {"battery_v": LOW_V, "why": f"not charging for {NOT_CHARGING_S:.0f} s"})]
    assert b.status.home_charges == 0


def test_go_home_and_charge_puts_the_fleet_to_sleep_first_with_a_scheduler() -> None:
    b = Bench(strategy="keep_alive")
    pool_of(b, [0.5, 0.6, 0.7])
    b.world.battery_v = LOW_V
    b.act.then(lambda: setattr(b.world, "battery_v", FULL_V))
    go_home_and_charge(b.crew, [])
    assert b.act.names() == ["set_phase", "sleep_order", "sleep_order", "sleep_order", "go_to", "hold",
                             "slow_telemetry", "wait_until"]
    assert {fields["why"] for _, fields in b.logged("sleep_order")} == {"home charge"}
    assert b.kinds()[-2:] == ["home_charge", "home_charged"]


# --- sleep orders -------------------------------------------------------------------------------------------


def test_reschedule_sends_the_schedulers_orders_and_writes_them_in_the_book() -> None:
    b = Bench(strategy="keep_alive")
    for m in range(1, 9):
        b.mussel(m, 5.0 * m, 0.0, 0.12 + 0.01 * m)  # more low aMussels than a few rounds reach in time
    b.act.fail("sleep_order", 8)  # not sent: planned as before
    sent = reschedule(b.crew)
    ordered = [args[0] for args in b.act.args("sleep_order")]
    assert ordered == sorted(ordered) and 8 in ordered and 1 not in ordered  # the most urgent stays awake
    assert {args[1] for args in b.act.args("sleep_order")} == {ASLEEP}
    assert sent == len(ordered) - 1
    assert b.status.orders.duties == {m: ASLEEP for m in ordered if m != 8}
    assert b.status.orders.sent == sent
    assert [fields["mussel"] for _, fields in b.logged("sleep_order")] == [m for m in ordered if m != 8]
    assert b.knows.duty(ordered[0]) == ASLEEP  # planned on from now on


def test_reschedule_wakes_a_sleeper_holding_a_good_charge() -> None:
    b = Bench(strategy="keep_alive")
    pool_of(b, [0.95, 0.9])
    b.status.orders.duties[1] = ASLEEP
    assert reschedule(b.crew) == 1
    assert b.act.args("sleep_order") == [(1, ALWAYS_ON)]
    assert b.status.orders.duties == {1: ALWAYS_ON}


def test_reschedule_without_a_scheduler_sends_nothing(b: Bench) -> None:
    pool_of(b, [0.12, 0.13, 0.14, 0.15, 0.16, 0.17])
    assert reschedule(b.crew) == 0
    assert b.act.calls == []


# --- the loop's shapes --------------------------------------------------------------------------------------


def test_rounds_strings_the_phases_in_the_papers_order(b: Bench) -> None:
    pool_of(b, [0.5, 0.4, 0.3, 0.2, 0.9])
    b.world.battery_v = 15.0
    homes = dict(b.world.homes)
    b.act.then(lambda: b.world.batteries.update({m: 0.995 for m in b.knows.docked().values()}),
               phase=Phase.CHARGING_WAIT)
    turns.rounds(b.crew)
    assert phases_set(b) == [Phase.IDLE_WAIT, Phase.PLAN_COLLECT, Phase.COLLECT, Phase.CHARGING_WAIT,
                             Phase.PLAN_REDEPLOY, Phase.REDEPLOY]
    assert [args[1] for args in b.act.args("dock")] == [4, 3, 2, 1]  # cautious: the lowest first
    assert b.act.args("undock") == [(4, 1), (3, 2), (2, 3), (1, 4)]  # from the last stop, nearest home first
    assert set(b.act.args("go_to")[-4:]) == {(homes[m], True) for m in (1, 2, 3, 4)}  # each taken home
    assert b.kinds() == ["plan_collection", *["call_up", "docked"] * 4, "plan_redeployment", *["released"] * 4]
    assert b.status.cycles == 1
    assert b.knows.docked() == {}
    assert {b.world.states[m] for m in (1, 2, 3, 4)} == {SINKING}


def test_rounds_goes_home_first_when_the_battery_would_not_cover_the_way_home(b: Bench) -> None:
    pool_of(b, [0.1, 0.1, 0.1, 0.1])
    b.world.position = b.at(40.0, 0.0)
    b.world.battery_v = 10.9  # below the reserve already
    b.act.then(lambda: setattr(b.world, "battery_v", FULL_V))
    turns.rounds(b.crew)
    assert phases_set(b) == [Phase.HOME_CHARGE]
    assert b.kinds() == ["home_charge", "home_charged"]
    assert b.act.args("go_to") == [(b.home, True)]


def test_rolling_puts_a_charged_one_back_then_fills_the_free_slots() -> None:
    b = Bench(strategy="rolling")
    assert turns.turn_for("rolling") is turns.rolling and turns.turn_for("cautious") is turns.rounds
    b.on_slot(1, 7, battery=0.995, home=b.at(30.0, 0.0))
    b.on_slot(2, 8, battery=0.5, home=b.at(35.0, 0.0))  # charging still: it stays on board
    pool_of(b, [0.3, 0.2])
    turns.rolling(b.crew)
    assert phases_set(b) == [Phase.IDLE_WAIT, Phase.PLAN_REDEPLOY, Phase.REDEPLOY, Phase.PLAN_COLLECT, Phase.COLLECT]
    assert b.act.args("undock") == [(1, 7)]
    assert b.kinds()[:3] == ["plan_redeployment", "released", "plan_collection"]
    assert sorted(m for _, m in b.act.args("dock")) == [1, 2]
    assert b.status.cycles == 1
    assert sorted(b.knows.docked().values()) == [1, 2, 8]
