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


def put_back_and_home_wh(knows: FleetKnowledge, on_board: list[int]) -> float:
    """Energy to put every aMussel of `on_board` back where it lives (in that order: no shorter than the
    planned route) and then go home, with the hotel load of the way and IDLE_LOOKAHEAD_S more, and the charge
    they still lack (they draw it through the link until they are let go: on the safe side, all of it), Wh."""
    budget, home = knows.settings.energy, knows.settings.home
    assert budget is not None and home is not None
    here = knows.position()
    stops = [knows.homes[m] for m in on_board if m in knows.homes]
    last = stops[-1] if stops else here
    metres = (route_length_m((here.lat, here.lon), [(s.lat, s.lon) for s in stops])
              + pair_distance_m(last.lat, last.lon, home[0], home[1]))
    view = knows.outlook()
    seconds = metres / knows.settings.apad_speed_mps + len(stops) * view.stop_s + IDLE_LOOKAHEAD_S
    missing = float(np.maximum(view.charged_frac - np.array([knows.battery(m) for m in on_board]), 0.0).sum())
    return budget.trip_wh(metres, seconds, missing)


def needs_home_loaded(knows: FleetKnowledge, volts: float | None = None) -> bool:
    """With aMussels on board: whether the battery (`volts`, default as last heard) would no longer cover putting
    them all back and going home, and the reserve (a rolling aPad always carries some; `needs_home` waits for
    none)."""
    budget, on_board = knows.settings.energy, list(knows.docked().values())
    volts = knows.battery_v() if volts is None else volts
    if budget is None or knows.settings.home is None or volts is None or not on_board:
        return False
    return not budget.affords(volts, put_back_and_home_wh(knows, on_board))


def needs_home(knows: FleetKnowledge, route: list[int], volts: float | None = None) -> bool:
    """Whether the battery (`volts`, default as last heard) would not cover `route` (see `trip_need_wh`) and the
    reserve; False without an energy budget or a battery reading, or with an aMussel on board."""
    budget = knows.settings.energy
    volts = knows.battery_v() if volts is None else volts
    if budget is None or knows.settings.home is None or volts is None or knows.docked():
        return False
    return not budget.affords(volts, trip_need_wh(knows, route))


def covers_loaded(knows: FleetKnowledge, route: list[int]) -> bool:
    """With aMussels on board: whether the battery covers `route` as a trip (`trip_need_wh`) and then putting
    back those on board and going home, and the reserve (counting the way home twice: on the safe side)."""
    budget, volts, on_board = knows.settings.energy, knows.battery_v(), list(knows.docked().values())
    if budget is None or knows.settings.home is None or volts is None:
        return True
    return budget.affords(volts, trip_need_wh(knows, route) + put_back_and_home_wh(knows, on_board))


def home_now(knows: FleetKnowledge, volts: float | None = None) -> bool:
    """Whether the aPad should head home as it stands, loaded or not (a wait that reads it: the registry
    watches it as a battery threshold, `gcs.mission.world`)."""
    return needs_home(knows, [], volts) or needs_home_loaded(knows, volts)
