"""The phases of the energy-sharing loop (the paper's Fig. 7), each a function of one aPad's `Crew`.

Idle wait -> plan collection -> collect (go to, call up, dock) x up to 4 -> charging wait ->
plan redeployment -> redeploy (go to the original position, undock, sink); and `recover`, which
settles what a crash interrupted. A phase reads the fleet through `crew.knows`
(`FleetKnowledge`), writes claims and homes in `crew.book` (`LoopBook`), commands the aPad through
`crew.act` (`ApadActions`) only, and writes `crew.status`;
it never reaches into another phase. The loop's shapes (`gcs.loop.turns`) string them together.
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numpy as np

from gcs.loop.book import charging_pool
from gcs.loop.control import Phase
from gcs.loop.crew import Crew
from gcs.loop.failed_docking import after_failed_docking, dock_again
from gcs.loop.fleet_knowledge import FleetKnowledge, Reads
from gcs.loop.trip_energy import needs_home
from gcs.loop.wake_times import all_charged_look_by, pool_look_by
from gcs.strategies import CollectStrategy, PlanInput, StrategyError, plan
from mussel_sim.vocabulary import MusselState

RESHARED = "another aPad's since the fleet was re-shared"
GONE_QUIET = "believed empty or unheard too long (acoustic)"


# --- collection ---------------------------------------------------------------------------------

def idle_wait(crew: Crew) -> None:
    """Hold until the pool holds enough candidates for the free slots (or orphans wait to be fetched)."""
    knows, act, mission = crew.knows, crew.act, crew.settings.mission
    act.set_phase(Phase.IDLE_WAIT)
    act.hold()

    def pool_full() -> bool:
        if needs_home(knows, []):
            return True  # the battery runs low while it waits: the turn takes it home first
        if crew.status.strategy == CollectStrategy.NONE or knows.too_late_to_call_up():
            return False
        if knows.orphans() and knows.free_slots() and act.link_up():
            return True  # left floating by a lost aPad: fetch them now
        free = len(knows.free_slots())
        if not free:
            return False
        # The pool first: it is empty at most looks, and the share's count (`pool_needed`, at least 1) is
        # the dearer of the two.
        found = len(charging_pool(knows, crew.book))
        return found > 0 and found >= min(knows.pool_needed(mission.min_pool), free) and act.link_up()

    act.wait_until(pool_full, look_by=functools.partial(pool_look_by, knows),
                   reads=Reads.FLEET | Reads.SHARES | Reads.OWN | Reads.MOVES)


def plan_collection(crew: Crew) -> list[int]:
    """The route for the free slots: orphans first, then the strategy's pick of the pool."""
    knows, status = crew.knows, crew.status
    crew.act.set_phase(Phase.PLAN_COLLECT)
    take_strategy_switch(crew)
    orphaned = knows.orphans()[:len(knows.free_slots())]
    planned = collection_route(crew, len(orphaned))
    route = orphaned + planned.route
    if route or status.route:  # one event for a run of empty plans (a strategy waiting)
        crew.log("plan_collection", strategy=planned.by, route=route, **planned.failed(status.strategy),
                 **({"orphans": orphaned} if orphaned else {}))
    status.route = route
    return route


def collection_route(crew: Crew, reserved: int = 0) -> Planned:
    """The strategy's route over the charging pool for the free slots but `reserved`."""
    knows = crew.knows
    inp = collection_input(crew, charging_pool(knows, crew.book), len(knows.free_slots()) - reserved)
    return strategy_route(crew, inp)


FALLBACK = CollectStrategy.CAUTIOUS  # plans the step a strategy failed (docs/strategies.md)


class Planned(NamedTuple):
    """A route and the strategy that planned it (the loop's, or `FALLBACK` for a step it failed)."""

    route: list[int]
    by: str

    def failed(self, strategy: str) -> dict[str, str]:
        """The event's word for a step the loop's strategy failed and the fallback planned, or nothing."""
        return {} if self.by == strategy else {"failed": strategy}


def strategy_route(crew: Crew, inp: PlanInput) -> Planned:
    """The strategy's route for this aPad. A strategy that raises or plans what the loop cannot act
    on (an aMussel that is not a candidate, one twice, more than the free slots) is logged
    (`strategy_failed`, with why) and the paper's cautious plans this step instead: the mission goes
    on, and the strategy is asked again at the next step. The event is logged at the 1st, 10th, 100th, ...
    failure (with the count): a strategy that always fails cannot flood the log."""
    try:
        return Planned(plan(crew.status.strategy, inp, crew.weights).get(crew.knows.apad_id, []), crew.status.strategy)
    except StrategyError as exc:
        crew.status.strategy_failures += 1
        failures = crew.status.strategy_failures
        if failures in (1, 10) or (failures >= 100 and math.log10(failures).is_integer()):  # a bounded log
            crew.log("strategy_failed", strategy=crew.status.strategy, why=str(exc), instead=str(FALLBACK),
                     failures=failures)
        return Planned(plan(FALLBACK, inp, crew.weights)[crew.knows.apad_id], str(FALLBACK))


def collection_input(crew: Crew, ids: list[int], capacity: int) -> PlanInput:
    """A planning step over these aMussels where they are now, from where the aPad is now."""
    knows = crew.knows
    where = [knows.location(m) for m in ids]
    position = knows.position()
    return PlanInput(
        apads={knows.apad_id: (position.lat, position.lon)},
        capacity={knows.apad_id: capacity},
        mussel_ids=np.array(ids, np.int64),
        lat_deg=np.array([w.lat for w in where]),
        lon_deg=np.array([w.lon for w in where]),
        battery_frac=knows.batteries(ids),
        outlook=knows.outlook(),
        drain_per_s=np.array([knows.drain_per_s(m) for m in ids], np.float64),
        wake_in_s=np.array([knows.wake_in_s(m) for m in ids], np.float64),
    )


def collect(crew: Crew, route: list[int]) -> None:
    """Fetch each aMussel of the route in turn: go to it, call it up, close in, dock it."""
    knows, act, status = crew.knows, crew.act, crew.status
    act.set_phase(Phase.COLLECT)
    route, fetched = list(route), set[int]()
    while route:
        act.check_end()  # between aMussels nothing is half done: an operator stop ends here
        act.wait_for_link()  # and nothing is lost by waiting here as long as the mission lasts
        route = recheck_route(crew, route)
        if not route:
            break
        mussel_id = route.pop(0)
        free = knows.free_slots()
        if not free:
            break
        if knows.too_late_to_call_up():
            crew.log("skip", mussel=mussel_id, why="too close to the mission end to dock it")
            break
        status.target_mussel = mussel_id
        if not knows.serves(mussel_id):
            crew.log("skip", mussel=mussel_id, why=RESHARED)
            continue
        called = call_up(crew, mussel_id)
        if not called and not knows.heard_alive(mussel_id):  # planned on a report since run down to empty
            crew.log("skip", mussel=mussel_id, why=GONE_QUIET)
            continue
        # From a call-up on, the waits ignore the mission end: the margin above leaves time to finish.
        if not act.go_to(knows.location(mussel_id), interruptible=not called):
            if called:
                sink(crew, mussel_id)
            continue
        if not called and not call_up(crew, mussel_id):
            crew.log("skip", mussel=mussel_id, why=RESHARED if not knows.serves(mussel_id) else
                     GONE_QUIET if not knows.heard_alive(mussel_id) else "no aPad within acoustic range")
            continue
        rise_s = knows.wake_in_s(mussel_id) + crew.settings.mussel_surfacing_s  # a sleeper's wake first
        if not act.wait_until(functools.partial(_floating_or_depleted, knows, mussel_id),
                              knows.call_up_wait_s(mussel_id), interruptible=False, holding_for_s=rise_s,
                              reads=Reads.FLEET):
            if taken_over(crew, mussel_id):
                continue
            crew.log("skip", mussel=mussel_id, why="did not surface", state=knows.state(mussel_id).name)
            sink(crew, mussel_id)  # it may surface later: it must not float there forever
            continue
        if knows.state(mussel_id) == MusselState.DEPLETED:  # no use waiting it out: it cannot move now
            crew.book.release(mussel_id)
            crew.log("skipped", mussel=mussel_id,
                     why="depleted at the surface" if knows.at_surface(mussel_id) else "depleted before it floated")
            continue
        # It surfaced where it was last localised underwater, give or take drift: close in.
        if taken_over(crew, mussel_id):
            continue
        if knows.distance_to(mussel_id) > 0.8 * crew.settings.dock_reach_m:
            act.go_to(knows.location(mussel_id), interruptible=False)
        if taken_over(crew, mussel_id):
            continue
        if act.dock(free[0], mussel_id) or dock_again(crew, free[0], mussel_id):
            crew.log("docked", mussel=mussel_id, slot=free[0])
            status.dockings.append((knows.clock.time(), mussel_id))
        else:
            sink(crew, mussel_id)
            crew.log("skip", mussel=mussel_id, why="docking failed")
            if after_failed_docking(crew, mussel_id, fetched):  # settled off its position: fetch it again
                route.insert(0, mussel_id)
    status.target_mussel = 0


def recheck_route(crew: Crew, route: list[int]) -> list[int]:
    """Before each leg: drop every aMussel of the route that can no longer be collected (a
    `skipped` event with the reason: depleted meanwhile, or its battery would give out before it
    floats), and if any was dropped plan the order of the rest again, from here, with the
    strategy (those already floating first, as planned)."""
    knows = crew.knows
    keep = []
    for mussel_id in route:
        why = knows.cannot_collect(mussel_id)
        if why is None:
            keep.append(mussel_id)
        else:
            crew.log("skipped", mussel=mussel_id, why=why)
    if len(keep) == len(route):
        return route
    floating = [m for m in keep if knows.floating(m)]
    rest = [m for m in keep if m not in floating]
    inp = collection_input(crew, rest, len(rest))
    planned = strategy_route(crew, inp) if rest else Planned([], crew.status.strategy)
    new = floating + planned.route
    if sorted(new) != sorted(keep):  # a strategy that would not take them all: keep the planned order
        new = keep
    crew.status.route = new
    crew.log("replan_collection", strategy=planned.by, route=new, **planned.failed(crew.status.strategy))
    return new


def call_up(crew: Crew, mussel_id: int) -> bool:
    """Claim the aMussel (never two aPads), note its home, and call it up if an aPad is within acoustic
    range (`ApadActions.call_up_if_in_range`); not called: the claim let go again. False: not called."""
    if not crew.book.claim(mussel_id):
        return False
    crew.book.note_home(mussel_id)
    if crew.act.call_up_if_in_range(mussel_id):
        return True
    crew.book.release(mussel_id)
    return False


def sink(crew: Crew, mussel_id: int) -> None:
    """Send a called-up aMussel down and see it go (`ApadActions.sink`); the claim on it is let go either
    way (one that does not answer floats unclaimed: an orphan its owner will come back for)."""
    crew.act.sink(mussel_id)
    crew.book.release(mussel_id)


def taken_over(crew: Crew, mussel_id: int) -> bool:
    """This aPad was lost long enough for another to take over its claim: leave the aMussel to that
    one (no sink: it is being fetched). Logged."""
    if not crew.knows.taken_over(mussel_id):
        return False
    crew.log("skip", mussel=mussel_id, why="taken over by another aPad while this one was unheard")
    return True


def _floating_or_depleted(knows: FleetKnowledge, mussel_id: int) -> bool:
    return knows.state(mussel_id) in (MusselState.FLOATING, MusselState.DEPLETED)


def take_strategy_switch(crew: Crew) -> None:
    """The operator's new strategy, if one was set, from this planning step on."""
    control, status = crew.control, crew.status
    with control.lock:
        new, control.strategy = control.strategy, None
    if new and new != status.strategy:
        crew.log("strategy_switch", old=status.strategy, new=new)
        status.strategy = new


# --- charging and redeployment ------------------------------------------------------------------

def charging_wait(crew: Crew) -> None:
    """Hold until every aMussel on board may go back (`FleetKnowledge.charged`)."""
    knows, act = crew.knows, crew.act
    act.set_phase(Phase.CHARGING_WAIT)
    act.hold()
    strategy = crew.status.strategy
    act.wait_until(lambda: all(knows.charged(m, strategy) for m in knows.docked().values()),
                   look_by=lambda: all_charged_look_by(knows, list(knows.docked().values()), strategy),
                   reads=Reads.FLEET | Reads.OWN)


def plan_redeployment(crew: Crew, only: set[int] | None = None) -> list[tuple[int, int]]:
    """Route of (slot, aMussel id) back to the original positions (of those docked, or of `only`)."""
    knows = crew.knows
    crew.act.set_phase(Phase.PLAN_REDEPLOY)
    docked = {s: m for s, m in knows.docked().items() if only is None or m in only}  # slot -> mussel
    ids = list(docked.values())
    for m in ids:
        crew.book.note_home(m)  # one docked with no home known (e.g. held since a crash): back to here
    position = knows.position()
    inp = PlanInput(
        apads={knows.apad_id: (position.lat, position.lon)},
        capacity={knows.apad_id: len(ids)},
        mussel_ids=np.array(ids, np.int64),
        lat_deg=np.array([knows.homes[m].lat for m in ids]),
        lon_deg=np.array([knows.homes[m].lon for m in ids]),
        battery_frac=np.array([knows.battery(m) for m in ids]),
    )
    strategy = crew.settings.mission.redeploy_strategy
    route = plan(strategy, inp, crew.weights)[knows.apad_id]
    slot_of = {m: s for s, m in docked.items()}
    crew.status.route = route
    crew.log("plan_redeployment", strategy=strategy, route=route)
    return [(slot_of[m], m) for m in route]


def redeploy(crew: Crew, route: list[tuple[int, int]]) -> None:
    """Take each aMussel home, undock it and send it down."""
    knows, act, status = crew.knows, crew.act, crew.status
    act.set_phase(Phase.REDEPLOY)
    act.begin_redeployment()
    for slot, mussel_id in route:
        act.check_end()  # between legs: no trip starts after the end (the rest stay on their slots)
        status.target_mussel = mussel_id
        act.wait_for_link()
        if not act.go_to(knows.homes[mussel_id]):
            crew.log("kept_on_board", mussel=mussel_id, slot=slot, why="its position could not be reached")
            continue
        if act.undock(slot, mussel_id):
            if knows.simulated(mussel_id):  # a local party: the command cannot be lost
                act.tell_to_sink(mussel_id)
                crew.book.release(mussel_id)
                act.let_go(mussel_id)  # not waited for here: the next leg gives it time
            else:
                sink(crew, mussel_id)  # over a radio: seen to leave the surface
            crew.log("released", mussel=mussel_id, slot=slot)
    status.target_mussel = 0


def charge_and_redeploy(crew: Crew) -> None:
    """One cycle's second half: wait out the charge of everything on board, take it all home."""
    charging_wait(crew)
    redeploy(crew, plan_redeployment(crew))
    crew.status.cycles += 1


# --- after a crash ------------------------------------------------------------------------------

def recover(crew: Crew) -> None:
    """After a crash: finish latches in motion, send down whatever was called up and not docked
    (of this aPad's share, with no other aPad's claim on it), and complete a charging cycle whose
    aMussels are still on board."""
    knows, act = crew.knows, crew.act
    act.sleep(2.0, interruptible=False)  # hear the aPad's slots and the fleet's status afresh
    if not act.wait_until(lambda: not knows.latches_in_motion(), crew.settings.surfacing_timeout_s,
                          interruptible=False):
        crew.log("gave_up", what="waiting for latches in motion", slots=knows.latches_in_motion())
    on_board = set(knows.docked().values())
    for mussel_id in knows.in_states((MusselState.FLOATING, MusselState.SURFACING)):
        # Several aPads: only what is this one's to handle (another may be latching it right now).
        if mussel_id not in on_board and knows.serves(mussel_id):
            crew.log("recover", mussel=mussel_id, action="sink", state=knows.state(mussel_id).name)
            sink(crew, mussel_id)
    if knows.docked():
        crew.log("recover", action="finish charging cycle", docked=sorted(on_board))
        charge_and_redeploy(crew)
