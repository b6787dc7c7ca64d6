"""Collection and redeployment strategies: one module per strategy behind one interface
(`base.Strategy`: `(PlanInput, CostWeights) -> Plan`), all registered in `STRATEGIES` by name.
docs/strategies.md says what each does and when it wins."""

from gcs.mission.strategies import (  # noqa: F401  (each module registers its strategy)
    cautious,
    greedy,
    least_slack,
    lookahead,
    none,
    rolling,
    route_optimal,
    weighted,
)
from gcs.mission.strategies.base import (
    COLLECT,
    REDEPLOY,
    STRATEGIES,
    CollectStrategy,
    CostWeights,
    Outlook,
    Plan,
    PlanInput,
    RedeployStrategy,
    Strategy,
    Traits,
    plan,
    route_length_m,
    strategy,
    traits,
)

__all__ = [
    "COLLECT", "REDEPLOY", "STRATEGIES", "CollectStrategy", "CostWeights", "Outlook", "Plan", "PlanInput",
    "RedeployStrategy", "Strategy", "Traits", "plan", "route_length_m", "strategy", "traits",
]
