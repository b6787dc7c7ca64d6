"""Cautious (the paper): lowest battery next."""

from __future__ import annotations

from gcs.strategies.base import CollectStrategy, CostWeights, Plan, PlanInput, energy_cost, sequence, strategy


@strategy(CollectStrategy.CAUTIOUS)
def cautious(inp: PlanInput, weights: CostWeights) -> Plan:
    """Lowest battery next, regardless of movement: protect the aMussels most in need."""
    return sequence(inp, lambda lat, lon, taken: -energy_cost(CostWeights(energy_per_frac=1.0), inp))
