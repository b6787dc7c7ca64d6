"""The one interface every collection and redeployment strategy shares, and its registry.

A solution is an ordered list of aMussel ids per aPad (`Plan`). Every strategy is a function
`(PlanInput, CostWeights) -> Plan` registered by name, so adding one is adding one module with one
registered function. Costs come from two modules with scale factors (the paper, section III):
distance in geodesic metres, and energy as the charge an aMussel lacks (1 - battery). What a
strategy may know beyond positions and batteries (mission time left, the battery model, the
aPad's speed) is in `PlanInput.outlook`; the paper's strategies do not read it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mussel_sim.battery import (
    DEFAULT_CHARGE,
    DEFAULT_DISCHARGE,
    ChargeProfile,
    charge_profile,
    discharge_profile,
    sim_minutes,
)
from mussel_sim.geo import distance_m

Plan = dict[int, list[int]]  # aPad system id -> aMussel ids in visiting order

PAPER_THETA = 30.0  # the paper's aMussel time scale: an outlook's default
PAPER_DRAIN_PER_S = discharge_profile(DEFAULT_DISCHARGE).rate_per_min * sim_minutes(PAPER_THETA, 1.0)
PAPER_CHARGE = charge_profile(DEFAULT_CHARGE)


@dataclass(frozen=True)
class Outlook:
    """Time and rates a strategy may plan with (defaults: the paper's pool runs, no end in sight)."""

    time_left_s: float = math.inf  # mission time left
    drain_per_s: float = PAPER_DRAIN_PER_S  # battery fraction an active aMussel uses per mission second
    charge: ChargeProfile = PAPER_CHARGE  # how a docked aMussel charges
    theta: float = PAPER_THETA  # aMussel time scale: the charge rates are per simulated minute
    speed_mps: float = 0.5  # the aPad's cruise speed
    stop_s: float = 40.0  # mission seconds at each collection stop besides travel: surfacing, docking
    charged_frac: float = 0.99  # docked aMussels are released at this

    def charge_time_s(self, from_frac: ArrayLike, to_frac: ArrayLike | None = None) -> NDArray[np.float64]:
        """Mission seconds a docked aMussel takes from `from_frac` to `to_frac` (default: charged),
        band by band of the charge profile. Shapes broadcast; 0 where it already holds `to_frac`."""
        start = np.asarray(from_frac, float)
        target = np.asarray(self.charged_frac if to_frac is None else to_frac, float)
        bounds = (0.0, *self.charge.thresholds, math.inf)
        total = np.zeros(np.broadcast(start, target).shape)
        for lo, hi, rate in zip(bounds[:-1], bounds[1:], self.charge.rates_per_min, strict=True):
            part = np.minimum(hi, target) - np.maximum(lo, start)
            total += np.maximum(part, 0.0) / (rate * sim_minutes(self.theta, 1.0))
        return total


@dataclass(frozen=True)
class PlanInput:
    """What a planning step sees. Arrays are (n,) over the candidate aMussels."""

    apads: dict[int, tuple[float, float]]  # aPad id -> (lat_deg, lon_deg) now
    capacity: dict[int, int]  # aPad id -> free slots
    mussel_ids: NDArray[np.int64]
    lat_deg: NDArray[np.float64]  # where each aMussel is now (collect) or must go back to (redeploy)
    lon_deg: NDArray[np.float64]
    battery_frac: NDArray[np.float64]
    outlook: Outlook = field(default_factory=Outlook)
    # Each candidate's own behaviour, as the GCS knows it (its profile, or the sleep order it was given):
    # battery fraction used per mission second (None: `outlook.drain_per_s` for every one), and mission
    # seconds until it can take a call-up (asleep, a call-up is held to its next wake; None: at once).
    drain_per_s: NDArray[np.float64] | None = None
    wake_in_s: NDArray[np.float64] | None = None

    def drains(self) -> NDArray[np.float64]:
        """Each candidate's drain, battery fraction per mission second. Shape (n,)."""
        if self.drain_per_s is None:
            return np.full(len(self.mussel_ids), self.outlook.drain_per_s)
        return np.asarray(self.drain_per_s, np.float64)

    def wake_waits(self) -> NDArray[np.float64]:
        """Mission seconds until each candidate hears a call-up (0: awake now). Shape (n,)."""
        if self.wake_in_s is None:
            return np.zeros(len(self.mussel_ids))
        return np.asarray(self.wake_in_s, np.float64)


@dataclass(frozen=True)
class CostWeights:
    """Scale factors of the two cost modules (`weighted`'s strategy; see docs/strategies.md).

    distance_per_m: cost of one metre the aPad travels to the next stop.
    energy_per_frac: cost saved by taking an aMussel that lacks the whole battery (1 - battery = 1);
    one that lacks half saves half. With energy_per_frac = 0 the cost is distance alone (greedy);
    as it grows past the pool's spread of distances the battery decides (cautious).
    """

    distance_per_m: float = 1.0
    energy_per_frac: float = 0.0


def distance_cost(weights: CostWeights, lat: float, lon: float, inp: PlanInput) -> NDArray[np.float64]:
    """Geodesic metres from (lat, lon) to every candidate, scaled. Shape (n,)."""
    n = len(inp.mussel_ids)
    return weights.distance_per_m * distance_m(np.full(n, lat), np.full(n, lon), inp.lat_deg, inp.lon_deg)


def energy_cost(weights: CostWeights, inp: PlanInput) -> NDArray[np.float64]:
    """Charging demand: the battery fraction each candidate lacks, scaled. Shape (n,)."""
    return weights.energy_per_frac * (1.0 - inp.battery_frac)


class CollectStrategy(StrEnum):
    """Which aMussels to collect, in which order: the paper's Greedy and Cautious, and ours."""

    GREEDY = "greedy"
    CAUTIOUS = "cautious"
    WEIGHTED = "weighted"
    NONE = "none"  # the baseline: never collect
    LEAST_SLACK = "least_slack"
    ROUTE_OPTIMAL = "route_optimal"
    ROLLING = "rolling"
    LOOKAHEAD = "lookahead"
    KEEP_ALIVE = "keep_alive"


class RedeployStrategy(StrEnum):
    GREEDY = "greedy"  # nearest original position next


COLLECT = tuple(CollectStrategy)
REDEPLOY = tuple(RedeployStrategy)

Strategy = Callable[[PlanInput, CostWeights], Plan]
STRATEGIES: dict[str, Strategy] = {}  # every strategy by name (`vil sweep` runs them all)


@dataclass(frozen=True)
class Traits:
    """How the loop runs a strategy beyond its plans (the paper's: neither)."""

    rolling: bool = False  # put each aMussel back as soon as it is charged; fill a free slot at once
    release_early: bool = False  # "charged" is also: enough to stay active to the mission end


TRAITS: dict[str, Traits] = {}
SHIPPED: set[str] = set()  # registered by `strategy` (the package's own); the rest came from outside (plugins)


def strategy(name: str, traits: Traits = Traits()) -> Callable[[Strategy], Strategy]:
    def register(fn: Strategy) -> Strategy:
        STRATEGIES[name] = fn
        TRAITS[name] = traits
        SHIPPED.add(name)
        return fn

    return register


def traits(name: str) -> Traits:
    return TRAITS.get(name, Traits())


@dataclass(frozen=True)
class ScheduleInput:
    """What a sleep-schedule step sees: the aMussels of this aPad's share on the seabed. Arrays (n,)."""

    mussel_ids: NDArray[np.int64]
    lat_deg: NDArray[np.float64]
    lon_deg: NDArray[np.float64]
    battery_frac: NDArray[np.float64]
    drain_per_s: NDArray[np.float64]  # as it works now (asleep on an order: the order's duty)
    awake_drain_per_s: NDArray[np.float64]  # always on (what waking it would make it use)
    asleep: NDArray[np.bool_]  # on a sleep order now
    orderable: NDArray[np.bool_]  # always on by its profile: the GCS may order it to sleep and back
    slots: int  # the aPad's
    start_s: float  # mission seconds before the aPad can start its next collection (inf: gone home)
    outlook: Outlook = field(default_factory=Outlook)


# id -> True: wake it (back to always on), False: put it to sleep; only the aMussels to change.
Scheduler = Callable[[ScheduleInput], dict[int, bool]]
SCHEDULERS: dict[str, Scheduler] = {}  # a strategy that orders sleep schedules: its scheduler, by name


def sleep_scheduler(name: str) -> Callable[[Scheduler], Scheduler]:
    """Register strategy `name`'s sleep scheduler: the loop asks it before each round
    (`gcs.loop.sleep_orders`) and sends what it decides as AMUSSEL_SLEEP_ORDER."""
    def register(fn: Scheduler) -> Scheduler:
        SCHEDULERS[name] = fn
        return fn

    return register


class StrategyError(ValueError):
    """A strategy that cannot be loaded or that failed to plan: what is wrong, in one line."""


def plan(name: str, inp: PlanInput, weights: CostWeights = CostWeights()) -> Plan:
    """Strategy `name`'s plan, checked (`check_plan`); `StrategyError` if it planned wrong, or if one
    from outside the package raised (a shipped one's exception is a bug of ours: it propagates)."""
    fn = STRATEGIES.get(name)
    if fn is None:
        raise StrategyError(f"unknown strategy {name!r} (known: {', '.join(STRATEGIES)})")
    if name in SHIPPED:
        return check_plan(name, fn(inp, weights), inp)
    try:
        made = fn(inp, weights)
    except Exception as exc:  # a user's strategy's bug is the strategy's: the loop says so and goes on
        raise StrategyError(f"strategy {name} raised {first_line(exc)}") from exc
    return check_plan(name, made, inp)


def first_line(exc: BaseException) -> str:
    """`Type: message` on one line (a message of several lines: its first)."""
    text = str(exc).strip()
    return f"{type(exc).__name__}: {text.splitlines()[0]}" if text else type(exc).__name__


def check_plan(name: str, plan: object, inp: PlanInput) -> Plan:
    """`plan` as the loop may act on it: a dict of aPad id -> candidate aMussel ids, each aMussel once,
    no more than the aPad's free slots. `StrategyError` saying what is wrong."""
    if not isinstance(plan, dict):
        raise StrategyError(f"strategy {name} returned {type(plan).__name__}, not a dict of aPad id -> aMussel ids")
    candidates = {int(m) for m in inp.mussel_ids}
    seen: set[int] = set()
    for apad, route in plan.items():
        if apad not in inp.apads:
            raise StrategyError(f"strategy {name} planned for aPad {apad!r}, which is not planning now")
        if not isinstance(route, list) or not all(_is_id(m) for m in route):
            raise StrategyError(f"strategy {name}: aPad {apad}'s route is not a list of aMussel ids: {route!r}")
        strange = [m for m in route if m not in candidates]
        if strange:
            raise StrategyError(f"strategy {name} planned aMussel {strange[0]}, which is not a candidate "
                                f"(candidates: {sorted(candidates)})")
        twice = seen.intersection(route) or ({m for m in route if route.count(m) > 1})
        if twice:
            raise StrategyError(f"strategy {name} planned aMussel {min(twice)} twice")
        if len(route) > inp.capacity.get(apad, 0):
            raise StrategyError(f"strategy {name} planned {len(route)} aMussels for aPad {apad}'s "
                                f"{inp.capacity.get(apad, 0)} free slots")
        seen.update(route)
    return {apad: [int(m) for m in route] for apad, route in plan.items()}


def _is_id(value: object) -> bool:
    return isinstance(value, int | np.integer) and not isinstance(value, bool)


def sequence(inp: PlanInput, step_cost: Callable[[float, float, NDArray[np.bool_]], NDArray[np.float64]],
             eligible: NDArray[np.bool_] | None = None) -> Plan:
    """Build each aPad's route one stop at a time, taking the cheapest remaining candidate.

    `step_cost(lat, lon, taken)` scores every candidate from the aPad's current stop; only
    `eligible` ones (default all) are taken. Ties go to the lower id, so plans are deterministic.
    """
    taken = np.zeros(len(inp.mussel_ids), bool) if eligible is None else ~eligible
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


def route_length_m(start: tuple[float, float], stops: list[tuple[float, float]]) -> float:
    """Geodesic length of start -> stops[0] -> ... in metres (the paper's movement cost of a plan)."""
    if not stops:
        return 0.0
    lats = np.array([start[0]] + [s[0] for s in stops])
    lons = np.array([start[1]] + [s[1] for s in stops])
    return float(distance_m(lats[:-1], lons[:-1], lats[1:], lons[1:]).sum())
