"""Collection and redeployment strategies: one module per strategy behind one interface
(`base.Strategy`: `(PlanInput, CostWeights) -> Plan`), all registered in `STRATEGIES` by name; one
from a file, a module or an installed package is loaded by `plugins.load_strategy`.
docs/strategies.md says what each does and when it wins, and how to write one of your own."""

from gcs.strategies import (  # noqa: F401  (each module registers its strategy)
    cautious,
    greedy,
    keep_alive,
    least_slack,
    lookahead,
    none,
    rolling,
    route_optimal,
    weighted,
)
from gcs.strategies.base import (
    COLLECT,
    REDEPLOY,
    SCHEDULERS,
    STRATEGIES,
    CollectStrategy,
    CostWeights,
    Outlook,
    Plan,
    PlanInput,
    RedeployStrategy,
    ScheduleInput,
    Scheduler,
    Strategy,
    StrategyError,
    Traits,
    check_plan,
    plan,
    route_length_m,
    strategy,
    traits,
)
from gcs.strategies.plugins import (
    ENTRY_POINT_GROUP,
    fingerprint,
    is_plugin,
    load_strategy,
    shipped_names,
    source_of,
    strategy_names,
)

__all__ = [
    "COLLECT", "ENTRY_POINT_GROUP", "REDEPLOY", "SCHEDULERS", "STRATEGIES", "CollectStrategy", "CostWeights", "Outlook",
    "Plan", "PlanInput", "RedeployStrategy", "ScheduleInput", "Scheduler", "Strategy", "StrategyError", "Traits",
    "check_plan", "fingerprint", "is_plugin",
    "load_strategy", "plan", "route_length_m", "shipped_names", "source_of", "strategy", "strategy_names", "traits",
]
