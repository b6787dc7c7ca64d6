"""What a report every model step would say now: a simulated aMussel's battery run forward from its last report.

The fleet reports by exception (`mussel_sim.report_policy`): an aMussel whose state has not changed
reports every few seconds, not every step. Between its reports the GCS takes the model's steps itself,
from the report to the last step at or before now, with the battery models the planner already plans
with: deployed (on the seabed, on its way up or down, floating), eq. (1) at its duty's drain; on a slot
of an aPad, eq. (2) by its charge profile; depleted, as reported. Whole steps, not the time since: at
any instant the GCS believes what the last report of a fleet reporting every step would have said, so
the planner's decisions fall where they fell then (to float rounding: the report is float32).

A sleep order sent since the report (`anchor`: when, and the battery believed then) changed the drain from
the fleet's first step after it: the old duty's run ends there and the new one's begins, so the belief does
not depend on how long ago the aMussel last spoke (a sleeper speaks only at its wakes).

Pure: the caller passes the report, the time and the models.
"""

from __future__ import annotations

from bisect import bisect_left

import numpy as np
from numpy.typing import NDArray

from gcs.link.telemetry import MusselView
from missiontime import seconds_to_us
from mussel_sim.battery import ChargeProfile, sim_minutes
from mussel_sim.comms import MODEL_STEP_S
from mussel_sim.vocabulary import MusselState

MODEL_STEP_US = seconds_to_us(MODEL_STEP_S)
EXACT_STEPS = 64  # stretches up to this many steps are taken step by step (`charged_forward`)


def steps_since(report_us: int, now_us: int) -> int:
    """The model's whole steps from a report made at `report_us` to `now_us`."""
    return max(now_us - report_us, 0) // MODEL_STEP_US


def steps_after(order_us: int, now_us: int) -> int:
    """The model's steps after an order heard at `order_us` up to `now_us`: its steps fall on whole multiples
    of the step (the first after the order takes it)."""
    return max(now_us // MODEL_STEP_US - order_us // MODEL_STEP_US, 0)


def charged_forward(battery: float, steps: int, charge: ChargeProfile, theta: float) -> float:
    """eq. (2) for `steps` steps from `battery`, as the fleet steps it (the band of the value before each step).

    A few steps (lockstep's reports come every few seconds) are taken one by one, to the bit; a long
    stretch (the event platform reports only changes) in closed form within each band, the steps near a
    band's edge one by one, so the band of each step is the one the fleet's would have."""
    dt_min = sim_minutes(theta, MODEL_STEP_S)
    thresholds, rates = charge.thresholds, charge.rates_per_min
    u, left = battery, steps
    while left > 0:
        if u >= 1.0:
            return 1.0
        band = bisect_left(thresholds, u)
        step = rates[band] * dt_min
        inside = int(((thresholds[band] if band < len(thresholds) else 1.0) - u) / step)  # steps surely in it
        if left > EXACT_STEPS and inside > EXACT_STEPS:
            taken = min(left, inside - 1)
            u, left = u + taken * step, left - taken
        else:
            u, left = min(u + step, 1.0), left - 1
    return u


def foreseen_battery(view: MusselView, now_us: int, drain_per_s: float, charge: ChargeProfile, theta: float,
                     released_us: int | None = None, anchor: tuple[int, float] | None = None) -> float:
    """The battery a report made now would carry: `view` run forward in whole model steps, drained at
    `drain_per_s` (never below 0); one DOCKED charged by `charge`, up to `released_us` if a slot has let
    go of it since (the fleet takes a release at its next step, which drains: every step up to the
    release's instant charged it, every one after drains it). `anchor`: (mission us, battery) believed when
    a sleep order last changed its duty; a deployed one's run at `drain_per_s` (the new duty's) starts
    there if the order came after the report (the module's docstring).
    """
    if view.state == MusselState.DEPLETED:
        return view.battery_frac
    if anchor is not None and anchor[0] > view.time_us and view.state != MusselState.DOCKED:
        steps = steps_after(anchor[0], now_us)
        return max(anchor[1] - steps * drain_per_s * MODEL_STEP_S, 0.0) if steps else anchor[1]
    steps = steps_since(view.time_us, now_us)
    if steps == 0:
        return view.battery_frac
    battery, drained = view.battery_frac, steps
    if view.state == MusselState.DOCKED:
        charging = steps if released_us is None else min(steps_since(view.time_us, released_us), steps)
        battery, drained = charged_forward(battery, charging, charge, theta), steps - charging
    return max(battery - drained * drain_per_s * MODEL_STEP_S, 0.0) if drained else battery


def foreseen_deployed(battery_frac: NDArray[np.float64], report_us: NDArray[np.int64], now_us: int,
                      drain_per_s: NDArray[np.float64]) -> NDArray[np.float64]:
    """`foreseen_battery` of many deployed aMussels at once (a table's columns), operation for operation."""
    steps = np.maximum(now_us - report_us, 0) // MODEL_STEP_US
    return np.maximum(battery_frac - steps * drain_per_s * MODEL_STEP_S, 0.0)
