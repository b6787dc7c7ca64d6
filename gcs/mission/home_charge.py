"""The aPad goes home to its charger when its battery would not cover the next trip.

A trip (`trip_need_wh`) is a round as the loop runs it: to each aMussel of the route and back to
it to redeploy it (the stops retraced), the charging wait of the route's aMussels, the energy their
charge draws through the inductive link, then the way home from the last stop, all at the hotel
load; `EnergyBudget` keeps a reserve beyond it. No route (idle): the way home alone. The aPad never
goes home with an aMussel on board (it would leave it off its position for hours): the check is
made with empty slots, before a round.

At home it holds at its charger (the SITL charges within `home_radius_m`, standing still) until the
battery holds `charged_frac`; if it does not charge (no charger heard charging for NOT_CHARGING_S
after it arrived), the wait ends with a `home_charge_failed` event and the mission goes on.
"""

from __future__ import annotations

import numpy as np

from gcs.api import Location
from gcs.mission.control import Phase
from gcs.mission.crew import Crew
from gcs.mission.fleet_knowledge import FleetKnowledge
from gcs.mission.sleep_orders import GOING_HOME, reschedule
from gcs.mission.strategies import route_length_m
from mussel_sim.geo import pair_distance_m

IDLE_LOOKAHEAD_S = 600.0  # idle: the hotel load this long is counted besides the way home
NOT_CHARGING_S = 120.0  # at home and not charging this long: the charger is not there or not working


def trip_need_wh(knows: FleetKnowledge, route: list[int]) -> float:
    """Energy the next trip takes, Wh: `route` collected, charged and redeployed, then the way home."""
    budget, home = knows.settings.energy, knows.settings.home
    assert budget is not None and home is not None
    here = knows.api.position(knows.apad_id)
    stops = [knows.api.mussels[m].location for m in route]
    out_m = route_length_m((here.lat, here.lon), [(s.lat, s.lon) for s in stops])
    last = stops[-1] if stops else here
    home_m = pair_distance_m(last.lat, last.lon, home[0], home[1])  # remembered: an idle wait prices it at every poll
    metres = 2.0 * out_m + home_m
    if not route:  # idle (priced at every poll of the wait): the way home and the hotel load alone
        return budget.trip_wh(metres, metres / knows.settings.apad_speed_mps + IDLE_LOOKAHEAD_S, 0.0)
    view = knows.outlook()
    batteries = np.array([knows.battery(m) for m in route])
    missing = float(np.maximum(view.charged_frac - batteries, 0.0).sum())
    charging_s = float(view.charge_time_s(batteries).max())
    seconds = metres / knows.settings.apad_speed_mps + 2 * len(route) * view.stop_s + charging_s
    return budget.trip_wh(metres, seconds, missing)


def needs_home(knows: FleetKnowledge, route: list[int]) -> bool:
    """Whether the battery, as last heard, would not cover `route` (see `trip_need_wh`) and the reserve;
    False without an energy budget or a battery reading, or with an aMussel on board."""
    budget = knows.settings.energy
    volts = knows.api.battery_v(knows.apad_id)
    if budget is None or knows.settings.home is None or volts is None or knows.docked():
        return False
    return not budget.affords(volts, trip_need_wh(knows, route))


def within_energy(crew: Crew, route: list[int]) -> list[int]:
    """`route` if the battery covers it; else, charged already (the route would not fit a full
    battery), its longest start that fits (a `route_trimmed` event); else home to charge first, and
    no route now (the turn plans again, charged)."""
    knows = crew.knows
    if not needs_home(knows, route):
        return route
    budget, volts = knows.settings.energy, knows.api.battery_v(knows.apad_id)
    if budget is not None and volts is not None and budget.charged(volts):
        fits = next((k for k in range(len(route) - 1, -1, -1) if not needs_home(knows, route[:k])), 0)
        crew.log("route_trimmed", route=route, kept=route[:fits], why="more than a charged battery covers")
        return route[:fits]
    go_home_and_charge(crew, route)
    return []


def go_home_and_charge(crew: Crew, route: list[int]) -> None:
    """Home, hold at the charger until charged (or until it is clear it does not charge), log both."""
    knows, act = crew.knows, crew.act
    budget, home = knows.settings.energy, knows.settings.home
    assert budget is not None and home is not None
    volts = knows.api.battery_v(knows.apad_id)
    act.set_phase(Phase.HOME_CHARGE)
    reschedule(crew, GOING_HOME, why="home charge")  # hours away: a strategy that orders sleep does so now
    crew.log("home_charge", battery_v=round(volts or 0.0, 3), trip_wh=round(trip_need_wh(knows, route), 1),
             route=route)
    act.go_to(Location(*home))
    act.command(act.api.hold)
    act.pace.hold()  # hours at the charger: slow telemetry (the battery's reports keep their rate)
    arrived_s = knows.clock.time()
    charging_seen = [arrived_s]

    def done() -> bool:
        view = knows.api.apad(knows.apad_id)
        if view.charging:
            charging_seen[0] = knows.clock.time()
        return (view.battery_v is not None and budget.charged(view.battery_v)) or (
            knows.clock.time() - charging_seen[0] >= NOT_CHARGING_S)

    act.wait_until(done)
    after = knows.api.battery_v(knows.apad_id) or 0.0
    if budget.charged(after):
        crew.status.home_charges += 1
        crew.log("home_charged", battery_v=round(after, 3), waited_s=round(knows.clock.time() - arrived_s, 1),
                 charging_heard=charging_seen[0] > arrived_s)
    else:
        crew.log("home_charge_failed", battery_v=round(after, 3), why=f"not charging for {NOT_CHARGING_S:.0f} s")
