"""What the next trip costs the aPad, and whether its battery covers it: reads over what the loop knows.

A trip (`trip_need_wh`) is a round as the loop runs it: to each aMussel of the route and back to
it to redeploy it (the stops retraced), the charging wait of the route's aMussels, the energy their
charge draws through the inductive link, then the way home from the last stop, all at the hotel
load; `EnergyBudget` keeps a reserve beyond it. No route (idle): the way home alone. The home charge
itself is a phase (`gcs.loop.home_charge`).
"""

from __future__ import annotations

import numpy as np

from gcs.loop.fleet_knowledge import FleetKnowledge
from gcs.strategies import route_length_m
from mussel_sim.geo import pair_distance_m

IDLE_LOOKAHEAD_S = 600.0  # idle: the hotel load this long is counted besides the way home


def trip_need_wh(knows: FleetKnowledge, route: list[int]) -> float:
    """Energy the next trip takes, Wh: `route` collected, charged and redeployed, then the way home."""
    budget, home = knows.settings.energy, knows.settings.home
    assert budget is not None and home is not None
    here = knows.position()
    stops = [knows.location(m) for m in route]
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
    volts = knows.battery_v()
    if budget is None or knows.settings.home is None or volts is None or knows.docked():
        return False
    return not budget.affords(volts, trip_need_wh(knows, route))
