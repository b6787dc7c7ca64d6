"""Keep alive: sleep schedules and charging managed together, so that no aMussel depletes.

The aPad charges `slots` aMussels a round. An always-on aMussel the queue will not reach before it
empties is ordered to sleep (Table I's hourly wake: ~14.6x longer on the same charge); a sleeper that
holds a good charge is woken back to always on when the queue, with it awake, still reaches everyone
in time. Before the aPad goes home to its charger (hours), every always-on aMussel is put to sleep
(`gcs.loop.sleep_orders`). Collection is least slack first, with each aMussel's own drain and the
wait for a sleeper's wake (`urgency.slack_s`).

What it trades: a sleeper counts as up (docs/long_term.md: monitoring on its schedule) but takes one
sample an hour instead of monitoring all the time; `samples_taken` / `samples_scheduled` and the
`sleep_order` events say how much of the mission was spent asleep.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.strategies.base import (
    CollectStrategy,
    CostWeights,
    Plan,
    PlanInput,
    ScheduleInput,
    Traits,
    sequence,
    sleep_scheduler,
    strategy,
)
from gcs.strategies.lookahead import dock_times_s
from gcs.strategies.routing import metres_matrix
from gcs.strategies.urgency import needs_charge, slack_s, time_to_depletion_s
from mussel_sim.battery import sim_minutes
from mussel_sim.behaviour import duty_cycle_rate_per_min

MARGIN_S = 120.0  # an aMussel must still hold this long when the aPad is due (a late trip, a sleeper's wake)
PICKUP_FRAC = 0.2  # a round's aMussels are charged from about this
WAKE_FRAC = 0.5  # a sleeper holding less sleeps on until charged: awake, it would soon need the aPad again
SLEEP_INTERVAL_S = 3600.0  # the order that puts one to sleep: Table I's hourly wake (aMussel seconds)
SLEEP_AWAKE_S = 10.0


@strategy(CollectStrategy.KEEP_ALIVE, Traits())
def keep_alive(inp: PlanInput, weights: CostWeights) -> Plan:
    """The load: least slack first (each candidate at its own drain, with the wait for its wake), of those
    that would deplete before the end; its order: the one that loses fewest on the way, then docks them
    soonest (a sleeper's wake holds the route: the awake one about to empty goes first)."""
    plan = sequence(inp, lambda lat, lon, taken: slack_s(inp, lat, lon), eligible=needs_charge(inp))
    return {apad: _best_order(inp, apad, route) for apad, route in plan.items()}


def _best_order(inp: PlanInput, apad: int, route: list[int]) -> list[int]:
    """Of every order of `route` (at most 4! = 24): fewest depleted before docking, then the least sum of
    docking times, from the aPad's position now (ties: the planned order)."""
    if len(route) < 2:
        return route
    at = {int(m): k for k, m in enumerate(inp.mussel_ids)}
    picks = np.array([at[m] for m in route])
    start = inp.apads[apad]
    metres = metres_matrix(np.concatenate(([start[0]], inp.lat_deg[picks])),
                           np.concatenate(([start[1]], inp.lon_deg[picks])))
    orders = np.array(list(itertools.permutations(range(len(route)))), np.intp)  # (n_orders, k), planned first
    stops = np.concatenate((np.zeros((len(orders), 1), np.intp), orders + 1), axis=1)
    legs_m = metres[stops[:, :-1], stops[:, 1:]]
    dock_s = dock_times_s(inp.outlook, legs_m, inp.wake_waits()[picks][orders])
    lost = (dock_s > time_to_depletion_s(inp)[picks][orders]).sum(axis=1)
    best = int(np.lexsort((dock_s.sum(axis=1), lost))[0])
    return [route[j] for j in orders[best]]


def leg_s(inp: ScheduleInput) -> float:
    """Mission seconds to fetch one aMussel: a typical leg (the median distance between them) and the stop."""
    n = len(inp.mussel_ids)
    leg_m = float(np.median(metres_matrix(inp.lat_deg, inp.lon_deg)[np.triu_indices(n, 1)])) if n > 1 else 0.0
    return leg_m / inp.outlook.speed_mps + inp.outlook.stop_s


@dataclass(frozen=True)
class Queue:
    """The aPad's queue over one schedule's aMussels: a fetch (`leg_s`) and a round (fetching `slots`
    aMussels, charging them from PICKUP_FRAC and taking each back), in mission seconds. Made once per
    schedule: the trial drains below change who is due when, never the legs."""

    inp: ScheduleInput
    leg_s: float
    round_s: float

    @staticmethod
    def of(inp: ScheduleInput) -> Queue:
        leg = leg_s(inp)
        return Queue(inp, leg, float(inp.outlook.charge_time_s(PICKUP_FRAC)) + 2 * inp.slots * leg)

    def due_s(self, drain_per_s: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """With these drains: each aMussel's time to depletion, and when the aPad would dock it if it
        takes them least time to depletion first, `slots` a round, from `start_s`. Shapes (n,)."""
        inp = self.inp
        ttd = inp.battery_frac / drain_per_s
        rank = np.empty(len(ttd), np.int64)
        rank[np.argsort(ttd, kind="stable")] = np.arange(len(ttd))
        slots = max(inp.slots, 1)
        due = inp.start_s + (rank // slots).astype(np.float64) * self.round_s + (rank % slots + 1) * self.leg_s
        return ttd, np.asarray(due, np.float64)

    def doomed(self, drain: NDArray[np.float64], awake: NDArray[np.bool_]) -> NDArray[np.bool_]:
        """Awake aMussels that would empty before their round (or the end) comes."""
        ttd, due = self.due_s(drain)
        return awake & (ttd < np.minimum(due, self.inp.outlook.time_left_s) + MARGIN_S)


@sleep_scheduler(CollectStrategy.KEEP_ALIVE)
def keep_alive_schedule(inp: ScheduleInput) -> dict[int, bool]:
    """Sleep for every orderable aMussel awake that the queue would not reach in time; then, fullest
    first, wake each sleeper holding WAKE_FRAC if nobody awake would be doomed by it."""
    asleep_drain = duty_cycle_rate_per_min(  # the fleet's model of the sleep order
        SLEEP_INTERVAL_S, SLEEP_AWAKE_S) * sim_minutes(inp.outlook.theta, 1.0)
    queue = Queue.of(inp)
    awake = inp.orderable & ~inp.asleep
    drain = np.asarray(inp.drain_per_s, np.float64).copy()
    for _ in range(len(drain)):  # each pass sends at least one more to sleep, or stops
        doomed = queue.doomed(drain, awake)
        if not doomed.any():
            break
        awake &= ~doomed
        drain[doomed] = asleep_drain
    for k in np.argsort(-inp.battery_frac, kind="stable"):
        if awake[k] or not inp.orderable[k] or inp.battery_frac[k] < WAKE_FRAC:
            continue
        trial_awake, trial_drain = awake.copy(), drain.copy()
        trial_awake[k], trial_drain[k] = True, inp.awake_drain_per_s[k]
        if not queue.doomed(trial_drain, trial_awake).any():
            awake, drain = trial_awake, trial_drain
    was_awake = inp.orderable & ~inp.asleep
    changed = inp.orderable & (awake != was_awake)
    return {int(inp.mussel_ids[k]): bool(awake[k]) for k in np.flatnonzero(changed)}
