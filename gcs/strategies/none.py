"""The baseline: never collect."""

from __future__ import annotations

from gcs.strategies.base import CollectStrategy, CostWeights, Plan, PlanInput, strategy


@strategy(CollectStrategy.NONE)
def no_charging(inp: PlanInput, weights: CostWeights) -> Plan:
    """The baseline: never collect."""
    return {apad_id: [] for apad_id in inp.apads}
