"""Least slack first: the aMussel that can wait least, from where the aPad will be."""

from __future__ import annotations

from gcs.strategies.base import CollectStrategy, CostWeights, Plan, PlanInput, Traits, sequence, strategy
from gcs.strategies.urgency import needs_charge, slack_s


@strategy(CollectStrategy.LEAST_SLACK, Traits(release_early=True))
def least_slack(inp: PlanInput, weights: CostWeights) -> Plan:
    """Next the candidate with the least slack (time to depletion minus time to reach it).

    Only candidates that would deplete before the mission ends are taken (`urgency.needs_charge`);
    none may be an empty plan (the loop waits). Docked aMussels go back as soon as they hold enough
    charge to last to the end (`Traits.release_early`).
    """
    return sequence(inp, lambda lat, lon, taken: slack_s(inp, lat, lon), eligible=needs_charge(inp))
