"""How urgent each candidate is, from the outlook: time to depletion, need, slack."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from gcs.strategies.base import PlanInput
from mussel_sim.geo import distance_m


def time_to_depletion_s(inp: PlanInput) -> NDArray[np.float64]:
    """Mission seconds until each candidate's battery is empty, working as now (each at its own drain:
    a sleeper lasts longer). Shape (n,)."""
    return inp.battery_frac / inp.drains()


def needs_charge(inp: PlanInput) -> NDArray[np.bool_]:
    """Which candidates would deplete before the mission ends (charging the others only costs
    them time on a slot). Shape (n,)."""
    return time_to_depletion_s(inp) < inp.outlook.time_left_s


def travel_s(inp: PlanInput, lat: float, lon: float) -> NDArray[np.float64]:
    """Mission seconds until the aPad, setting off from (lat, lon) now, has each candidate docked: the
    trip there, or until it wakes to hear the call-up if that is later, and the stop. Shape (n,)."""
    n = len(inp.mussel_ids)
    metres = distance_m(np.full(n, lat), np.full(n, lon), inp.lat_deg, inp.lon_deg)
    return np.maximum(metres / inp.outlook.speed_mps, inp.wake_waits()) + inp.outlook.stop_s


def slack_s(inp: PlanInput, lat: float, lon: float) -> NDArray[np.float64]:
    """Time to depletion minus time to reach and dock it from (lat, lon): how long it can wait. Shape (n,)."""
    return time_to_depletion_s(inp) - travel_s(inp, lat, lon)
