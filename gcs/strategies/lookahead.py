"""Look-ahead: choose this trip's load by what it does to the next trip, with the charging model."""

from __future__ import annotations

import itertools

import numpy as np
from numpy.typing import NDArray

from gcs.strategies.base import CollectStrategy, CostWeights, Outlook, Plan, PlanInput, Traits, strategy
from gcs.strategies.routing import metres_matrix
from gcs.strategies.urgency import needs_charge, slack_s, time_to_depletion_s

SHORTLIST = 8  # loads are drawn from this many candidates of least slack (<= 2080 ordered loads)
METRE_S = 1.0  # a metre of travel weighs as much as a second of aMussel time lost
UNDOCK_S = 10.0  # at each stop of the redeployment besides travel


def _depleted_s(o: Outlook, reached_s: NDArray[np.float64], ttd_s: NDArray[np.float64],
                drain_per_s: NDArray[np.float64]) -> NDArray[np.float64]:
    """Seconds depleted of aMussels reached at `reached_s` that deplete at `ttd_s` (draining `drain_per_s`):
    one reached too late cannot surface any more, so it is down from its depletion to the end (or for a
    battery's life)."""
    end_s = np.minimum(o.time_left_s, 1.0 / drain_per_s)
    return np.where(reached_s > ttd_s, np.maximum(end_s - ttd_s, 0.0), 0.0)


def dock_times_s(o: Outlook, legs_m: NDArray[np.float64], wake_s: NDArray[np.float64]) -> NDArray[np.float64]:
    """When each stop of each load is docked: after the leg there, or once that aMussel wakes to hear the
    call-up if that is later (a sleeper holds the route), then the stop. Shapes (n, k)."""
    if not np.any(wake_s > 0):  # nobody asleep: the sums as they always were (the same plans, bit for bit)
        return np.cumsum(legs_m / o.speed_mps + o.stop_s, axis=1)
    dock_s = np.empty_like(legs_m)
    t = np.zeros(legs_m.shape[0])
    for j in range(legs_m.shape[1]):
        t = np.maximum(t + legs_m[:, j] / o.speed_mps, wake_s[:, j]) + o.stop_s
        dock_s[:, j] = t
    return dock_s


def _with_apad(inp: PlanInput, apad: tuple[float, float], pick: NDArray[np.intp]) -> NDArray[np.float64]:
    """Metres between the aPad (row/column 0) and the shortlisted candidates. Shape (k + 1, k + 1)."""
    return metres_matrix(np.concatenate(([apad[0]], inp.lat_deg[pick])), np.concatenate(([apad[1]], inp.lon_deg[pick])))


def _score(inp: PlanInput, loads: NDArray[np.intp], metres: NDArray[np.float64], short: NDArray[np.intp],
           needy: NDArray[np.intp], capacity: int) -> NDArray[np.float64]:
    """Predicted cost of each ordered load (rows of `loads`, shortlist positions) over two trips:
    aMussel seconds depleted (to the end, for one whose trip comes too late), seconds charged
    aMussels wait on the slots for the slowest, and metres travelled (`METRE_S`). Shape (n_loads,)."""
    o = inp.outlook
    n, k = loads.shape
    stops = np.concatenate((np.zeros((n, 1), np.intp), loads + 1), axis=1)
    legs_m = metres[stops[:, :-1], stops[:, 1:]]  # (n, k)
    drains = inp.drains()
    dock_s = dock_times_s(o, legs_m, inp.wake_waits()[short[loads]])
    ttd = time_to_depletion_s(inp)
    member_ttd, member_drain = ttd[short[loads]], drains[short[loads]]
    lost = _depleted_s(o, dock_s, member_ttd, member_drain).sum(axis=1)
    at_dock = np.maximum(member_ttd - dock_s, 0.0) * member_drain
    target = np.minimum(o.charged_frac, member_drain * (o.time_left_s - dock_s) + 0.05)
    ready_s = dock_s + o.charge_time_s(at_dock, np.maximum(target, at_dock))
    release_s = ready_s.max(axis=1)
    waited = (release_s[:, None] - ready_s).sum(axis=1)
    trip_m = legs_m.sum(axis=1)
    next_trip_s = release_s + trip_m / o.speed_mps + UNDOCK_S * k
    # The next trip: the rest of the needy, least time to depletion first, one leg each.
    member = np.zeros((n, len(inp.mussel_ids)), bool)
    np.put_along_axis(member, short[loads], True, axis=1)
    order = np.argsort(np.where(member[:, needy], np.inf, ttd[needy]), axis=1, kind="stable")  # (n, m)
    rest = np.take_along_axis(np.where(member[:, needy], np.inf, ttd[needy]), order, axis=1)
    rest_drain = drains[needy][order]
    leg_s = np.median(metres[1:, 1:]) / o.speed_mps + o.stop_s if len(short) > 1 else o.stop_s
    rank = np.arange(rest.shape[1])
    pickup_s = next_trip_s[:, None] + (np.minimum(rank, capacity - 1) + 1) * leg_s
    second = rest[:, :capacity]
    at_second = rest_drain[:, :capacity] * np.maximum(second - next_trip_s[:, None], 0.0)
    charge_s = o.charge_time_s(np.where(np.isfinite(second), at_second, 1.0)).max(axis=1)
    # Beyond the next trip, a coarse queue: trips of `capacity` at the next one's period.
    period_s = charge_s + 2 * capacity * leg_s
    pickup_s = pickup_s + (rank // capacity)[None, :] * period_s[:, None]
    due = np.isfinite(rest)
    lost_rest = np.where(due, _depleted_s(o, pickup_s, np.where(due, rest, 0.0), rest_drain), 0.0)
    return lost + waited + lost_rest.sum(axis=1) + METRE_S * trip_m


@strategy(CollectStrategy.LOOKAHEAD, Traits(release_early=True))
def lookahead(inp: PlanInput, weights: CostWeights) -> Plan:
    """The load and order, of up to a load of the SHORTLIST least-slack candidates that would deplete
    before the end, whose two trips (this one, and the next one taking the most urgent of the rest
    after this one's charging, timed with the charge profile) cost least (`_score`)."""
    plan: Plan = {}
    free = needs_charge(inp)
    for apad_id in sorted(inp.apads):
        capacity = inp.capacity.get(apad_id, 0)
        needy = np.flatnonzero(free)
        if capacity <= 0 or needy.size == 0:
            plan[apad_id] = []
            continue
        apad = inp.apads[apad_id]
        short = needy[np.argsort(slack_s(inp, *apad)[needy], kind="stable")[:SHORTLIST]]
        metres = _with_apad(inp, apad, short)
        best: tuple[float, list[int]] = (np.inf, [])
        for size in range(1, min(capacity, len(short)) + 1):
            loads = np.array(list(itertools.permutations(range(len(short)), size)), np.intp)
            score = _score(inp, loads, metres, short, needy, capacity)
            i = int(np.argmin(score))
            if score[i] < best[0]:
                best = (float(score[i]), [int(short[j]) for j in loads[i]])
        free[best[1]] = False
        plan[apad_id] = [int(inp.mussel_ids[j]) for j in best[1]]
    return plan
