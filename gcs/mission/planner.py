"""Kept for the modules that import the planner from here: the strategies live in
`gcs.mission.strategies` (one module each)."""

from gcs.mission.strategies import (
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
    plan,
    route_length_m,
    strategy,
)

__all__ = [
    "COLLECT", "REDEPLOY", "STRATEGIES", "CollectStrategy", "CostWeights", "Outlook", "Plan", "PlanInput",
    "RedeployStrategy", "Strategy", "plan", "route_length_m", "strategy",
]
