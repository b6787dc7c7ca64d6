"""Weighted: the paper's two cost modules, distance and energy, with scale factors."""

from __future__ import annotations

from gcs.strategies.base import (
    CollectStrategy,
    CostWeights,
    Plan,
    PlanInput,
    distance_cost,
    energy_cost,
    sequence,
    strategy,
)


@strategy(CollectStrategy.WEIGHTED)
def weighted(inp: PlanInput, weights: CostWeights) -> Plan:
    """Cheapest next by `distance_scale` x metres - `energy_scale` x (1 - battery).

    The scale factors trade metres for charge: with `distance_scale = 1` an `energy_scale` of E
    makes an aMussel lacking 10 % more charge worth going 0.1 E metres further. E = 0 is greedy;
    E far above the pool's spread of distances is cautious. The shipped E = 40 (the scenario's
    `mission.energy_scale`) lets a 25 % battery difference outweigh 10 m, a third of the pool:
    near neighbours are taken together unless one is much lower.
    """
    return sequence(
        inp,
        lambda lat, lon, taken: distance_cost(weights, lat, lon, inp) - energy_cost(weights, inp),
    )
