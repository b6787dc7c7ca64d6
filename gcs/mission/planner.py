"""Mission planner: collection and redeployment strategies over one solution encoding.

A solution is an ordered list of aMussel ids per aPad (`Plan`). Every strategy is a function
`(PlanInput, CostWeights) -> Plan` registered by name, so adding one is adding one function.
Costs come from two modules with scale factors (the paper, section III): distance in geodesic
metres, and energy as the charge an aMussel lacks (1 - battery).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
from numpy.typing import NDArray

from mussel_sim.geo import distance_m

Plan = dict[int, list[int]]  # aPad system id -> aMussel ids in visiting order


@dataclass(frozen=True)
class PlanInput:
    """What a planning step sees. Arrays are (n,) over the candidate aMussels."""

    apads: dict[int, tuple[float, float]]  # aPad id -> (lat_deg, lon_deg) now
    capacity: dict[int, int]  # aPad id -> free slots
    mussel_ids: NDArray[np.int64]
    lat_deg: NDArray[np.float64]  # where each aMussel is now (collect) or must go back to (redeploy)
    lon_deg: NDArray[np.float64]
    battery_frac: NDArray[np.float64]


@dataclass(frozen=True)
class CostWeights:
    """Scale factors of the two cost modules."""

    distance_per_m: float = 1.0
    energy_per_frac: float = 0.0


def distance_cost(weights: CostWeights, lat: float, lon: float, inp: PlanInput) -> NDArray[np.float64]:
    """Geodesic metres from (lat, lon) to every candidate, scaled. Shape (n,)."""
    n = len(inp.mussel_ids)
    return weights.distance_per_m * distance_m(np.full(n, lat), np.full(n, lon), inp.lat_deg, inp.lon_deg)


def energy_cost(weights: CostWeights, inp: PlanInput) -> NDArray[np.float64]:
    """Charging demand: the battery fraction each candidate lacks, scaled. Shape (n,)."""
    return weights.energy_per_frac * (1.0 - inp.battery_frac)


Strategy = Callable[[PlanInput, CostWeights], Plan]
STRATEGIES: dict[str, Strategy] = {}


class CollectStrategy(StrEnum):
    """Which aMussels to collect, in which order (the paper's Greedy and Cautious, and ours)."""

    GREEDY = "greedy"
    CAUTIOUS = "cautious"
    WEIGHTED = "weighted"
    NONE = "none"  # the baseline: never collect


class RedeployStrategy(StrEnum):
    GREEDY = "greedy"  # nearest original position next


COLLECT = tuple(CollectStrategy)
REDEPLOY = tuple(RedeployStrategy)


def strategy(name: str) -> Callable[[Strategy], Strategy]:
    def register(fn: Strategy) -> Strategy:
        STRATEGIES[name] = fn
        return fn

    return register


def _sequence(inp: PlanInput, step_cost: Callable[[float, float, NDArray[np.bool_]], NDArray[np.float64]]) -> Plan:
    """Build each aPad's route one stop at a time, taking the cheapest remaining candidate.

    `step_cost(lat, lon, taken)` scores every candidate from the aPad's current stop. Ties go
    to the lower id, so plans are deterministic.
    """
    taken = np.zeros(len(inp.mussel_ids), bool)
    plan: Plan = {}
    order = np.argsort(inp.mussel_ids, kind="stable")
    for apad_id in sorted(inp.apads):
        lat, lon = inp.apads[apad_id]
        route: list[int] = []
        for _ in range(inp.capacity.get(apad_id, 0)):
            if taken.all():
                break
            cost = step_cost(lat, lon, taken)[order]
            cost[taken[order]] = np.inf
            pick = order[int(np.argmin(cost))]
            taken[pick] = True
            route.append(int(inp.mussel_ids[pick]))
            lat, lon = float(inp.lat_deg[pick]), float(inp.lon_deg[pick])
        plan[apad_id] = route
    return plan


@strategy(CollectStrategy.GREEDY)
def greedy(inp: PlanInput, weights: CostWeights) -> Plan:
    """Nearest next: the closest remaining aMussel from where the aPad will be.

    As a redeployment strategy the positions are the aMussels' original ones: Greedy redeploy.
    """
    return _sequence(inp, lambda lat, lon, taken: distance_cost(CostWeights(1.0), lat, lon, inp))


@strategy(CollectStrategy.CAUTIOUS)
def cautious(inp: PlanInput, weights: CostWeights) -> Plan:
    """Lowest battery next, regardless of movement: protect the aMussels most in need."""
    return _sequence(inp, lambda lat, lon, taken: -energy_cost(CostWeights(energy_per_frac=1.0), inp))


@strategy(CollectStrategy.WEIGHTED)
def weighted(inp: PlanInput, weights: CostWeights) -> Plan:
    """Distance and energy costs with the scenario's scale factors (more energy weight = more cautious)."""
    return _sequence(
        inp,
        lambda lat, lon, taken: distance_cost(weights, lat, lon, inp) - energy_cost(weights, inp),
    )


@strategy(CollectStrategy.NONE)
def no_charging(inp: PlanInput, weights: CostWeights) -> Plan:
    """The baseline: never collect."""
    return {apad_id: [] for apad_id in inp.apads}


def plan(name: str, inp: PlanInput, weights: CostWeights = CostWeights()) -> Plan:
    try:
        fn = STRATEGIES[name]
    except KeyError:
        raise ValueError(f"unknown strategy {name!r} (known: {', '.join(sorted(STRATEGIES))})") from None
    return fn(inp, weights)


def route_length_m(start: tuple[float, float], stops: list[tuple[float, float]]) -> float:
    """Geodesic length of start -> stops[0] -> ... in metres (the paper's movement cost of a plan)."""
    if not stops:
        return 0.0
    lats = np.array([start[0]] + [s[0] for s in stops])
    lons = np.array([start[1]] + [s[1] for s in stops])
    return float(distance_m(lats[:-1], lons[:-1], lats[1:], lons[1:]).sum())
