"""Rolling: no rounds. Each aMussel goes back as soon as it is charged, and a freed slot is filled at once."""

from __future__ import annotations

from gcs.mission.strategies.base import CollectStrategy, CostWeights, Plan, PlanInput, Traits, strategy
from gcs.mission.strategies.least_slack import least_slack


@strategy(CollectStrategy.ROLLING, Traits(rolling=True, release_early=True))
def rolling(inp: PlanInput, weights: CostWeights) -> Plan:
    """For the slots free now, least slack first among those that would deplete before the end.

    The loop (`gcs.mission.rolling_loop.rolling_round`) asks again whenever a slot is free, and puts
    each docked aMussel back once it is charged (or holds enough to last to the end) instead of
    waiting for the whole load.
    """
    return least_slack(inp, weights)
