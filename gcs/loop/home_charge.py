"""The aPad goes home to its charger when its battery would not cover the next trip (`gcs.loop.trip_energy`
prices the trip). The aPad never goes home with an aMussel on board (it would leave it off its position
for hours): the check is made with empty slots, before a round.

At home it holds at its charger (the SITL charges within `home_radius_m`, standing still) until the
battery holds `charged_frac`; if it does not charge (no charger heard charging for NOT_CHARGING_S
after it arrived), the wait ends with a `home_charge_failed` event and the mission goes on.
"""

from __future__ import annotations

from gcs.link.apad_api import Location
from gcs.loop.control import Phase
from gcs.loop.crew import Crew
from gcs.loop.sleep_orders import GOING_HOME, reschedule
from gcs.loop.trip_energy import needs_home, trip_need_wh

NOT_CHARGING_S = 120.0  # at home and not charging this long: the charger is not there or not working


def within_energy(crew: Crew, route: list[int]) -> list[int]:
    """`route` if the battery covers it; else, charged already (the route would not fit a full
    battery), its longest start that fits (a `route_trimmed` event); else home to charge first, and
    no route now (the turn plans again, charged)."""
    knows = crew.knows
    if not needs_home(knows, route):
        return route
    budget, volts = knows.settings.energy, knows.battery_v()
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
    volts = knows.battery_v()
    act.set_phase(Phase.HOME_CHARGE)
    reschedule(crew, GOING_HOME, why="home charge")  # hours away: a strategy that orders sleep does so now
    crew.log("home_charge", battery_v=round(volts or 0.0, 3), trip_wh=round(trip_need_wh(knows, route), 1),
             route=route)
    act.go_to(Location(*home))
    act.hold()
    act.slow_telemetry()  # hours at the charger (the battery's reports keep their rate)
    arrived_s = knows.clock.time()
    charging_seen = [arrived_s]

    def done() -> bool:
        if knows.charging_at_home():
            charging_seen[0] = knows.clock.time()
        volts = knows.battery_v()
        return (volts is not None and budget.charged(volts)) or (
            knows.clock.time() - charging_seen[0] >= NOT_CHARGING_S)

    act.wait_until(done, look_by=lambda: charging_seen[0] + NOT_CHARGING_S)  # a charger that does not charge
    after = knows.battery_v() or 0.0
    if budget.charged(after):
        crew.status.home_charges += 1
        crew.log("home_charged", battery_v=round(after, 3), waited_s=round(knows.clock.time() - arrived_s, 1),
                 charging_heard=charging_seen[0] > arrived_s)
    else:
        crew.log("home_charge_failed", battery_v=round(after, 3), why=f"not charging for {NOT_CHARGING_S:.0f} s")
