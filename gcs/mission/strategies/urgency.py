"""How urgent each candidate is, from the outlook: time to depletion, need, slack."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from gcs.mission.strategies.base import PlanInput
from mussel_sim.geo import distance_m


def time_to_depletion_s(inp: PlanInput) -> NDArray[np.float64]:
    """Mission seconds until each candidate's battery is empty, working as now. Shape (n,)."""
    return inp.battery_frac / inp.outlook.drain_per_s


def needs_charge(inp: PlanInput) -> NDArray[np.bool_]:
    """Which candidates would deplete before the mission ends (charging the others only costs
    them time on a slot). Shape (n,)."""
    return time_to_depletion_s(inp) < inp.outlook.time_left_s


def travel_s(inp: PlanInput, lat: float, lon: float) -> NDArray[np.float64]:
    """Mission seconds the aPad takes from (lat, lon) to each candidate, stopping there. Shape (n,)."""
    n = len(inp.mussel_ids)
    metres = distance_m(np.full(n, lat), np.full(n, lon), inp.lat_deg, inp.lon_deg)
    return metres / inp.outlook.speed_mps + inp.outlook.stop_s


def slack_s(inp: PlanInput, lat: float, lon: float) -> NDArray[np.float64]:
    """Time to depletion minus time to reach and dock it from (lat, lon): how long it can wait. Shape (n,)."""
    return time_to_depletion_s(inp) - travel_s(inp, lat, lon)
