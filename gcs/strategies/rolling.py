"""Rolling: no rounds. Each aMussel goes back as soon as it is charged, and a freed slot is filled at once."""

from __future__ import annotations

from gcs.strategies.base import CollectStrategy, CostWeights, Plan, PlanInput, Traits, strategy
from gcs.strategies.route_optimal import route_optimal


@strategy(CollectStrategy.ROLLING, Traits(rolling=True, release_early=True))
def rolling(inp: PlanInput, weights: CostWeights) -> Plan:
    """For the slots free now, the route-optimal pick among those that would deplete before the end.

    The loop (`gcs.loop.turns.rolling`) asks again whenever a slot is free, and puts
    each docked aMussel back once it is charged (or holds enough to last to the end) instead of
    waiting for the whole load. Filling by least slack alone sends the aPad across the bay for each
    slot (bay24: 900 m a mission against cautious's 430 m); the route-optimal pick weighs the detour.
    """
    return route_optimal(inp, weights)
