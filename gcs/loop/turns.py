"""The loop's shapes: one turn of each, chosen by the strategy's traits (`strategies.Traits`).

`rounds` is the paper's: wait for a full pool, collect, charge everything, redeploy everything.
`rolling` puts each aMussel back as soon as it is charged and fills a freed slot at once. A turn
strings phases (`gcs.loop.phases`) together; the loop (`gcs.loop.energy_sharing`) repeats the turn its
strategy asks for. A new shape is a new function here and a trait that picks it.
"""

from __future__ import annotations

from collections.abc import Callable

from gcs.loop.control import Phase
from gcs.loop.crew import Crew
from gcs.loop.home_charge import go_home_and_charge, within_energy
from gcs.loop.phases import (
    charge_and_redeploy,
    collect,
    collection_route,
    idle_wait,
    plan_collection,
    plan_redeployment,
    redeploy,
)
from gcs.loop.sleep_orders import reschedule
from gcs.loop.trip_energy import covers_loaded, home_now, needs_home, needs_home_loaded
from gcs.loop.wake_times import any_charged_look_by, earliest
from gcs.strategies import traits

Turn = Callable[[Crew], None]

REPLAN_S = 10.0  # a strategy that takes none of the pool is asked again this much later
LOOK_S = 5.0  # the rolling wait plans again this often for a free slot


def rounds(crew: Crew) -> None:
    """Idle wait, plan and collect; then, with anything on board, charge it all and take it all home.
    Before each, with nothing on board: home to charge if the battery would not cover the trip."""
    if recharged(crew):
        return
    reschedule(crew)  # a strategy that orders sleep schedules: before the round
    idle_wait(crew)
    if recharged(crew):
        return
    route = within_energy(crew, plan_collection(crew))  # none now if it went home: planned again, charged
    if route:
        collect(crew, route)
    elif not crew.knows.docked():  # the strategy takes none of the pool yet: look again later
        crew.act.set_phase(Phase.IDLE_WAIT)
        crew.act.hold_for(REPLAN_S)
    if crew.knows.docked():
        charge_and_redeploy(crew)


def rolling(crew: Crew) -> None:
    """Wait until an aMussel on board is charged or a free slot has a candidate the strategy takes;
    put back the charged ones (nearest first), then fetch what the strategy plans for the free slots.
    First, when the battery would no longer cover putting back everyone on board and the way home: all of
    them back, charged or not, and home to charge (without it a rolling aPad ran flat at work)."""
    knows, act, strategy = crew.knows, crew.act, crew.status.strategy
    if needs_home_loaded(knows):  # it always carries someone, so `recharged` alone would never send it home
        crew.log("home_first", on_board=sorted(knows.docked().values()), battery_v=round(knows.battery_v() or 0, 3))
        redeploy(crew, plan_redeployment(crew))
        go_home_and_charge(crew, [])
        return
    if recharged(crew):
        return
    act.set_phase(Phase.IDLE_WAIT)
    act.hold()
    next_look_s = 0.0

    def work() -> bool:
        nonlocal next_look_s
        if home_now(knows):  # the battery: home (next turn), not another wait
            return True
        if any(knows.charged(m, strategy) for m in knows.docked().values()):
            return True
        if knows.clock.time() < next_look_s or not knows.free_slots() or knows.too_late_to_call_up():
            return False
        next_look_s = knows.clock.time() + LOOK_S
        if not act.link_up():
            return False
        if knows.orphans():
            return True
        route = collection_route(crew).route  # with some on board, a candidate only if the way home stays
        return bool(route) and (not knows.docked() or covers_loaded(knows, route[:1]))

    def look_by() -> float | None:  # a charge done, or the next look for a free slot
        looks = [next_look_s] if knows.free_slots() else []
        return earliest(looks + [t for t in [any_charged_look_by(knows, list(knows.docked().values()), strategy)]
                                 if t is not None])

    act.wait_until(work, look_by=look_by)
    if home_now(knows):
        return
    done = {m for m in knows.docked().values() if knows.charged(m, strategy)}
    if done:
        redeploy(crew, plan_redeployment(crew, only=done))
        crew.status.cycles += 1
    if knows.free_slots() and not knows.too_late_to_call_up():
        planned = plan_collection(crew)
        if knows.docked():  # with some on board, the longest start of the route that leaves the way home
            route = planned[:next((k for k in range(len(planned), 0, -1) if covers_loaded(knows, planned[:k])), 0)]
        else:
            route = within_energy(crew, planned)
        if route:
            collect(crew, route)


def recharged(crew: Crew) -> bool:
    """Home to charge, if the battery would not cover the way home and its reserve (waiting)."""
    if not needs_home(crew.knows, []):
        return False
    go_home_and_charge(crew, [])
    return True


def turn_for(strategy: str) -> Turn:
    """The turn the loop repeats for this collection strategy."""
    return rolling if traits(strategy).rolling else rounds
