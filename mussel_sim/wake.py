"""When a sleeping aMussel wakes: its schedule as a pure function of its id, its profile and the time.

An aMussel on a wake schedule (interval I, awake a, in its own simulated seconds) wakes at the
simulated times

    tau_k = (k + phase) * I,   k integer,   phase = frac(id * GOLDEN)

and is awake over [tau_k, tau_k + a). The phase comes from the aMussel's id alone (the golden-ratio
sequence spreads any set of ids evenly over the interval, and two fleets with the same ids wake
alike whatever the seed), so the GCS can compute every aMussel's next wake from what it knows: the
id, the schedule it ordered or the scenario gave, and the mission time. Simulated time is mission
time x theta, counted from mission time 0 (`sim_s`), the same for the fleet model and the planner.

Intervals are half open on the left: `wakes_between(t0, t1)` counts the wakes in (t0, t1], as a
fleet step from t0 to t1 sees them.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from missiontime import US_PER_S

GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0  # 0.618...: frac(id * GOLDEN) is as even as a sequence gets


def sim_s(time_us: int, theta: float) -> float:
    """The aMussels' simulated seconds at mission time `time_us` (their clock starts with the mission's)."""
    return theta * (time_us / US_PER_S)


def phase(mussel_ids: ArrayLike) -> NDArray[np.float64]:
    """Each aMussel's wake phase, a fraction of its interval in [0, 1), from its id."""
    return np.mod(np.asarray(mussel_ids, np.float64) * GOLDEN, 1.0)


def wake_index(mussel_ids: ArrayLike, interval_s: ArrayLike, t_sim_s: float) -> NDArray[np.float64]:
    """k of the latest wake at or before simulated time `t_sim_s` (intervals > 0), as floats."""
    return np.floor(t_sim_s / np.asarray(interval_s, np.float64) - phase(mussel_ids))


def wakes_between(mussel_ids: ArrayLike, interval_s: ArrayLike, t0_sim_s: float,
                  t1_sim_s: float) -> NDArray[np.int64]:
    """How many wakes each aMussel starts in (t0, t1] of simulated time (intervals > 0)."""
    later = wake_index(mussel_ids, interval_s, t1_sim_s)
    return (later - wake_index(mussel_ids, interval_s, t0_sim_s)).astype(np.int64)


def awake_between(mussel_ids: ArrayLike, interval_s: ArrayLike, awake_s: ArrayLike, t0_sim_s: float,
                  t1_sim_s: float) -> NDArray[np.bool_]:
    """Whether each aMussel is awake at some time in (t0, t1] of simulated time (intervals > 0): its
    latest wake at or before t1 lasts past t0. With t0 == t1: awake at that instant."""
    interval = np.asarray(interval_s, np.float64)
    start = (wake_index(mussel_ids, interval, t1_sim_s) + phase(mussel_ids)) * interval
    return np.asarray(start + np.asarray(awake_s, np.float64) > t0_sim_s)


def next_wake_sim_s(mussel_ids: ArrayLike, interval_s: ArrayLike, t_sim_s: float) -> NDArray[np.float64]:
    """Simulated time of each aMussel's first wake after `t_sim_s`; +inf where the interval is 0
    (always on: never asleep). The fleet state keeps it (`FleetState.next_wake_sim_s`) so a step
    only looks closer at the aMussels whose wake has come."""
    interval = np.asarray(interval_s, np.float64)
    out = np.full(interval.shape, np.inf)
    on = interval > 0
    if on.any():
        ids = np.asarray(mussel_ids)[on]
        out[on] = (wake_index(ids, interval[on], t_sim_s) + 1.0 + phase(ids)) * interval[on]
    return out


def next_wake_s(mussel_id: int, interval_s: float | None, awake_s: float | None, t_s: float, theta: float) -> float:
    """Mission time [s] from which the aMussel is next awake, at or after mission time `t_s`: `t_s`
    itself if it is awake then (or always on: `interval_s` None or 0), else its next wake. Pure:
    the planner's way to know when a call-up will be heard (`mussel_sim.fleet` holds one till then)."""
    if not interval_s:
        return t_s
    tau = theta * t_s
    start = (float(wake_index([mussel_id], [interval_s], tau)[0]) + float(phase([mussel_id])[0])) * interval_s
    if start + (awake_s or 0.0) > tau:
        return t_s
    return (start + interval_s) / theta
