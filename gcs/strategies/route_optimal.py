"""Route-optimal pick: which candidates and in which exact order, traded against their need."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from gcs.strategies.base import CollectStrategy, CostWeights, Plan, PlanInput, Traits, strategy
from gcs.strategies.routing import best_route
from gcs.strategies.urgency import time_to_depletion_s

# What the aPad may travel to save one aMussel a whole mission of depletion. The pool is 30 m
# across and the bay 65 m: the most urgent are always worth it, and of two close in need the
# nearer wins.
PRIZE_M = 200.0


def lost_share(inp: PlanInput) -> NDArray[np.float64]:
    """The share of the time left (or of a full battery's life, with no end in sight) each candidate
    would spend depleted if never charged. Shape (n,), in [0, 1]."""
    horizon = np.minimum(inp.outlook.time_left_s, 1.0 / inp.drains())
    return np.clip((horizon - time_to_depletion_s(inp)) / horizon, 0.0, 1.0)


@strategy(CollectStrategy.ROUTE_OPTIMAL, Traits(release_early=True))
def route_optimal(inp: PlanInput, weights: CostWeights) -> Plan:
    """Up to a load of candidates and the exact order minimising metres travelled plus PRIZE_M x the
    share of time each one left out would spend depleted (`routing.best_route`, exact). Candidates
    that last to the mission end have no prize and are never taken."""
    prize = PRIZE_M * lost_share(inp)
    plan: Plan = {}
    free = np.ones(len(inp.mussel_ids), bool)
    for apad_id in sorted(inp.apads):
        route = best_route(inp.apads[apad_id], inp.lat_deg, inp.lon_deg, np.where(free, prize, 0.0),
                           inp.capacity.get(apad_id, 0))
        free[route] = False
        plan[apad_id] = [int(inp.mussel_ids[k]) for k in route]
    return plan
