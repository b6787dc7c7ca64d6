"""Greedy (the paper): nearest next."""

from __future__ import annotations

from gcs.strategies.base import CollectStrategy, CostWeights, Plan, PlanInput, distance_cost, sequence, strategy


@strategy(CollectStrategy.GREEDY)
def greedy(inp: PlanInput, weights: CostWeights) -> Plan:
    """Nearest next: the closest remaining aMussel from where the aPad will be.

    As a redeployment strategy the positions are the aMussels' original ones: Greedy redeploy.
    """
    return sequence(inp, lambda lat, lon, taken: distance_cost(CostWeights(1.0), lat, lon, inp))
