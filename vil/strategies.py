"""What a strategy of your own needs (docs/strategies.md): the function's argument and result types,
its traits, and the geodesic distance the shipped strategies use.

    from vil.strategies import CostWeights, Plan, PlanInput

    def slack_first(inp: PlanInput, weights: CostWeights) -> Plan: ...
"""

from gcs.strategies import CostWeights, Outlook, Plan, PlanInput, Traits
from mussel_sim.geo import distance_m

__all__ = ["CostWeights", "Outlook", "Plan", "PlanInput", "Traits", "distance_m"]
