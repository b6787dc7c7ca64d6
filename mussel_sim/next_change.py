"""How far the fleet's model may be stepped in one go: the steps of its own course that change nothing
discontinuously, for the event platform (`FleetRunner.register(..., events=True)`).

With no input, each aMussel's course between discontinuities is a closed form that `fleet.step` takes
exactly for any step length: the battery linear by eq. (1) or by one band of eq. (2), a transit timer
counting down with its depth linear, a sleeper's wakes and samples counted by `wake` (its state,
on which a sample's being taken depends, unchanged). What a step treats discontinuously, each found
as J, the first one-period step of lockstep whose outcome a straight continuation would not give:

- a SURFACING / SINKING timer ends (FLOATING, ACTIVE: the step ends in another state);
- a deployed battery (every state but DOCKED and DEPLETED) reaches 0: DEPLETED, clamped at 0;
- a docked battery reaches 1 (the clamp starts) or crosses a charge band's threshold of eq. (2) (the
  band is chosen by u before each step, `ChargeProfile.rate_per_min`);
- a sleeper with a call-up held (`FleetState.surface_held`) is awake: the call-up goes
  (`fleet_sleep.Sleepers.awoken`). A sleeper without one wakes, samples and sleeps in closed form.

Steps 1 .. J - 1 may be taken as one; step J is taken alone, as lockstep takes it, so a transition
lands on the very instant lockstep has it and is counted (uptime, state times, samples) for one step.
Inputs (commands, latches, orders) and the recorder's day boundaries are the runner's business.
Each J is taken a hair early where it sits on a whole step (float noise decides it either way in
lockstep's sums): one more single step, never a step too far. Pure and clock-free.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from missiontime import US_PER_S
from mussel_sim.battery import sim_minutes
from mussel_sim.fleet_sleep import sleeping_fleet
from mussel_sim.fleet_state import DEPLETED, DOCKED, SINKING, SURFACING, TIMER_EPS_S, FleetParams, FleetState
from mussel_sim.wake import sim_s

NEVER = math.inf
_MARGIN = 1e-9  # relative: a crossing this close to a whole step is counted at the earlier one


def _first_step(x: NDArray[np.float64]) -> float:
    """The smallest J >= 1 with J >= x (x in steps), a hair early at a whole step; inf for none."""
    if not x.size:
        return NEVER
    return float(max(1.0, math.ceil(float(x.min()) * (1.0 - _MARGIN) - _MARGIN)))


def first_change_step(state: FleetState, params: FleetParams, step_s: float) -> float:
    """J: the first step of `step_s` from `state` (1 = the next) whose outcome is discontinuous, with no
    input (see the module docstring); inf if none ever comes."""
    st, u = state.state, state.battery_frac
    table, profile = state.profiles, state.profile
    dt_min = sim_minutes(params.theta, step_s)
    first = NEVER

    transit = np.flatnonzero((st == SURFACING) | (st == SINKING))
    if transit.size:  # step J leaves timer - J * step <= eps
        first = min(first, _first_step((state.timer_s[transit] - TIMER_EPS_S) / step_s))

    deployed = np.flatnonzero((st != DOCKED) & (st != DEPLETED))
    if deployed.size:  # u - J * d <= 0
        drop = table.rate_per_min[profile[deployed]] * dt_min
        falls = drop > 0
        first = min(first, _first_step(u[deployed][falls] / drop[falls]))

    docked = np.flatnonzero(st == DOCKED)
    if docked.size:
        first = min(first, _charge_change(u, docked, state, dt_min))

    held = np.flatnonzero(state.surface_held)
    if held.size and sleeping_fleet(table, profile):
        first = min(first, _held_wake(state, held, params.theta, step_s))
    return first


def _charge_change(u: NDArray[np.float64], docked: NDArray[np.intp], state: FleetState, dt_min: float) -> float:
    """The first step of a docked battery's that reaches 1 or starts in the next band of eq. (2)."""
    first = NEVER
    which = state.profile[docked]
    for k in np.unique(which).tolist():
        sel = docked[which == k]
        charge = state.profiles.profiles[int(k)].charge
        thresholds = np.asarray(charge.thresholds, np.float64)
        rates = np.asarray(charge.rates_per_min, np.float64)
        u0 = u[sel]
        band = thresholds.searchsorted(u0, side="left")
        rise = rates[band] * dt_min
        filling = (u0 < 1.0) & (rise > 0)
        u0, band, rise = u0[filling], band[filling], rise[filling]
        # u0 + J * rise >= 1: the clamp's step
        first = min(first, _first_step((1.0 - u0) / rise))
        below = band < thresholds.size
        if below.any():  # the step after the one that leaves u above its band's bound: u0 + (J-1) rise > bound
            bound = thresholds[band[below]]
            first = min(first, _first_step((bound - u0[below]) / rise[below] + 1.0 + _MARGIN))
    return first


def _held_wake(state: FleetState, held: NDArray[np.intp], theta: float, step_s: float) -> float:
    """The first step in which a sleeper whose call-up is held is awake (`Sleepers.awake`)."""
    table, p = state.profiles, state.profile[held]
    interval, awake = table.interval_s[p], table.awake_s[p]
    t0 = sim_s(state.time_us, theta)
    still_awake = (state.next_wake_sim_s[held] - interval + awake > t0) | (interval == 0)
    if still_awake.any():
        return 1.0
    # The step whose end (mission time) is at or past its next wake.
    wake_mission_s = state.next_wake_sim_s[held] / theta - state.time_us / US_PER_S
    return _first_step(wake_mission_s / step_s)


def steps_at_once(state: FleetState, params: FleetParams, step_s: float) -> float:
    """How many steps of `step_s` from `state` may be taken as one with no input (J - 1, >= 0; inf: any)."""
    return first_change_step(state, params, step_s) - 1.0


def next_change_s(state: FleetState, params: FleetParams, step_s: float = 1.0) -> float:
    """Mission seconds from `state` that one step may cover with nothing discontinuous in it, a whole
    number of steps of `step_s` (0: the next step holds a change, take it alone; inf: nothing ever changes
    without an input). Stepping to it changes nothing discontinuously; one step of `step_s` past it does."""
    return steps_at_once(state, params, step_s) * step_s
