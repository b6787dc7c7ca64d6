"""The aMussel fleet model: one pure step over numpy arrays, every agent at once.

    new_state, events = step(state, inputs, params, rng, dt_s)

No I/O, no clock, no mutation of the arguments (state arrays are read-only views): the runner in
`comms.py` turns MAVLink traffic into `FleetInputs` and the returned `FleetState` into messages.
Same seed, same start state, same inputs => bit-identical states.

Life cycle (`MusselState`, uint8 per agent):

    ACTIVE --surface cmd, aPad in acoustic range--> SURFACING --surfacing_time_s--> FLOATING
    FLOATING --sink cmd--> SINKING --sinking_time_s--> ACTIVE
    any --dock event (latched in slot s of aPad a)--> DOCKED --release event--> SINKING
    any but DOCKED --battery reaches 0--> DEPLETED (cannot surface; docking it anyway charges it)

Each agent follows its behaviour profile (`mussel_sim.behaviour`, `FleetState.profile`): its
discharge while deployed, its charge while docked, and for a sleeping one a wake schedule
(`mussel_sim.wake`). A sleeping agent stays ACTIVE on the seabed; a SURFACE command that finds it
asleep is held until its next wake (`mussel_sim.fleet_sleep`, which also counts its samples).

Within one step, in this order: sleep orders, release events, dock events, sink commands, surface
commands (held ones whose wake has come among them; the range check uses positions at the start of
the step and the aPad positions in the inputs), then SURFACING/SINKING timers, battery (DOCKED
charges, every other state discharges at its profile's rate: buoyancy motors and electronics stay
on), depletion, samples, positions (docked agents follow their aPad,
the rest move with current and random drift) and depths; a DEPLETED agent stays at the depth where
its battery gave out (at the surface if it was floating). Uptime is the recorder's business
(`mussel_sim.recorder`): an agent counts as active in step k by its state at the end of step k.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cache

import numpy as np
from numpy.typing import NDArray

from missiontime import US_PER_S
from mussel_sim.battery import step_battery
from mussel_sim.behaviour import step_battery_profiles
from mussel_sim.drift import NoCurrent, random_drift_m, summed_drift_m
from mussel_sim.fleet_sleep import Sleepers, apply_orders
from mussel_sim.fleet_state import (
    ACTIVE,
    DEPLETED,
    DOCKED,
    EMPTY_IDS,
    FLOATING,
    N_STATES,
    SINKING,
    SURFACING,
    TIMER_EPS_S,
    FleetInputs,
    FleetParams,
    FleetState,
    StepEvents,
)
from mussel_sim.geo import planar_distance_m
from mussel_sim.memo import LastMade


@dataclass
class _Applied:
    """Indices `(k,)` of what the commands and events of one step did (scratch, never returned)."""

    released: NDArray[np.intp]
    docked: NDArray[np.intp]
    submerged: NDArray[np.intp]
    surfaced: NDArray[np.intp]
    refused_range: NDArray[np.intp]
    refused_depleted: NDArray[np.intp]
    ignored: NDArray[np.intp]
    unknown: NDArray[np.int64]
    held: NDArray[np.intp]  # surface commands held for the agent's wake


_NONE = np.zeros(0, np.intp)
_NOTHING = _Applied(_NONE, _NONE, _NONE, _NONE, _NONE, _NONE, _NONE, EMPTY_IDS, _NONE)


def _apply_commands(
    state: FleetState,
    inputs: FleetInputs,
    params: FleetParams,
    st: NDArray[np.uint8],
    timer: NDArray[np.float64],
    dock_apad: NDArray[np.uint8],
    dock_slot: NDArray[np.uint8],
    sleepers: Sleepers | None = None,
    unknown_orders: NDArray[np.int64] = EMPTY_IDS,
) -> _Applied:
    """Apply release, dock, sink, surface in that order, in place on the step's working arrays
    (and on `sleepers`' held call-ups: held, taken at a wake, cancelled)."""
    unknown: list[NDArray[np.int64]] = [unknown_orders] if unknown_orders.size else []

    def known(ids: NDArray[np.int64]) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
        idx, ok = state.index_of(ids)
        if not ok.all():
            unknown.append(ids[~ok])
        return idx[ok], ok

    rel, _ = known(inputs.release_ids)
    rel = rel[st[rel] == DOCKED]  # a slot letting go of an aMussel it never held changes nothing
    st[rel] = SINKING
    timer[rel] = params.sinking_time_s
    dock_apad[rel] = 0
    dock_slot[rel] = 0

    # The aPad's latch is the authority on docking (as in the paper), whatever state we thought.
    dock, ok = known(inputs.dock_ids)
    submerged = dock[(st[dock] == ACTIVE) | (st[dock] == SINKING)]
    st[dock] = DOCKED
    timer[dock] = 0.0
    dock_apad[dock] = inputs.dock_apad[ok]
    dock_slot[dock] = inputs.dock_slot[ok]

    sink, _ = known(inputs.sink_ids)
    can_sink = st[sink] == FLOATING
    st[sink[can_sink]] = SINKING
    timer[sink[can_sink]] = params.sinking_time_s

    asked, _ = known(inputs.surface_ids)
    held = _NONE
    if sleepers is not None:
        sleepers.clear(np.concatenate([dock, sink]))  # docked: no call-up to wait for; sink: called off
        asked, held = sleepers.hold_asleep(asked, st)
        asked = np.unique(np.concatenate([asked, sleepers.awoken(st, inputs.wake_ids)]))
    depleted = st[asked] == DEPLETED  # below 3600 mV it may no longer be able to surface
    can_surface = st[asked] == ACTIVE
    ignored = np.concatenate([sink[~can_sink], asked[~can_surface & ~depleted]])
    surf = asked[can_surface]
    in_range = np.zeros(surf.shape, bool)
    if inputs.apad_ids.size and surf.size:
        dist = planar_distance_m(
            state.x_m[surf][:, None], state.y_m[surf][:, None], inputs.apad_x_m[None, :], inputs.apad_y_m[None, :]
        )
        in_range = dist.min(axis=1) <= params.acoustic_range_m
    st[surf[in_range]] = SURFACING
    timer[surf[in_range]] = params.surfacing_time_s

    return _Applied(
        released=rel,
        docked=dock,
        submerged=submerged,
        surfaced=surf[in_range],
        refused_range=surf[~in_range],
        refused_depleted=asked[depleted],
        ignored=ignored,
        unknown=np.unique(np.concatenate(unknown)) if unknown else EMPTY_IDS,
        held=held,
    )


def step(
    state: FleetState,
    inputs: FleetInputs,
    params: FleetParams,
    rng: np.random.Generator,
    dt_s: float,
    step_period_s: float | None = None,
) -> tuple[FleetState, StepEvents]:
    """Advance the fleet by `dt_s` seconds of mission time (simulated time: theta * dt_s).

    Exact for any `dt_s` over which nothing changes discontinuously (`mussel_sim.next_change`): the
    battery and transit timers are linear, wakes and samples counted in closed form. The random drift's
    half-width is per step of `step_period_s`: a longer step draws the drift of each of its steps and moves
    by their sum, as many small ones would, draw for draw (`drift.summed_drift_m`); None: one step whatever
    its length (lockstep's steps).
    A current moves an aMussel by its velocity at the step's start: exact for a uniform current, an
    Euler step of the whole `dt_s` for a gridded one."""
    ids = state.ids
    # The last state's arrays are read-only: copied before the first change (most steps change none).
    st, timer, dock_apad, dock_slot = state.state, state.timer_s, state.dock_apad, state.dock_slot
    time_us = state.time_us + round(dt_s * US_PER_S)

    # --- sleep orders, commands and dock events ------------------------------------------------
    table, profile, next_wake, unknown_orders = state.profiles, state.profile, state.next_wake_sim_s, EMPTY_IDS
    if inputs.sleep_ids.size:
        table, profile, next_wake, unknown_orders = apply_orders(state, inputs, table, profile, params.theta)
    sleepers = Sleepers.of(state, table, profile, next_wake, params.theta, time_us)
    has_commands = (inputs.release_ids.size + inputs.dock_ids.size + inputs.sink_ids.size + inputs.surface_ids.size
                    + unknown_orders.size + inputs.wake_ids.size + (sleepers is not None and sleepers.any_held_awake()))
    applied = _NOTHING
    if has_commands:
        st, timer, dock_apad, dock_slot = st.copy(), timer.copy(), dock_apad.copy(), dock_slot.copy()
        applied = _apply_commands(state, inputs, params, st, timer, dock_apad, dock_slot, sleepers, unknown_orders)

    # --- SURFACING / SINKING timers (a command given now has already run for this step) ----
    trans = _IN_TRANSIT[st].nonzero()[0]
    trans_at_start = trans.size
    floating = resumed = trans[:0]
    if trans.size:
        if not has_commands:
            st, timer = st.copy(), timer.copy()
        timer[trans] -= dt_s
        done = trans[timer[trans] <= TIMER_EPS_S]
        timer[done] = 0.0
        was_surfacing = st[done] == SURFACING
        floating, resumed = done[was_surfacing], done[~was_surfacing]
        st[floating] = FLOATING
        st[resumed] = ACTIVE

    # --- battery and depletion ---------------------------------------------------------------
    docked_mask = st == DOCKED
    if sleepers is None:  # everyone on the first profile, always on: eqs. (1)-(2) as the paper has them
        first = table.profiles[0]
        u = step_battery(state.battery_frac, docked_mask, first.discharge, first.charge, params.theta, dt_s)
    else:
        u = step_battery_profiles(state.battery_frac, docked_mask, table, profile, params.theta, dt_s)
    empty = u <= 0.0
    newly_depleted = np.flatnonzero(empty & ~docked_mask & (st != DEPLETED)) if empty.any() else _NONE
    if newly_depleted.size:
        st = st.copy() if st is state.state else st
        timer = timer.copy() if timer is state.timer_s else timer
        st[newly_depleted] = DEPLETED
        timer[newly_depleted] = 0.0

    # --- sleeping agents: call-ups held, samples -------------------------------------------------
    taken, due, held = state.samples_taken, state.samples_due, state.surface_held
    if sleepers is not None:
        sleepers.clear(newly_depleted)
        taken, due = sleepers.samples(st, taken, due)
        held, next_wake = sleepers.held, sleepers.next_wake

    # --- positions ---------------------------------------------------------------------------
    x = state.x_m.copy()
    y = state.y_m.copy()
    if not isinstance(params.current, NoCurrent):
        ve, vn = params.current.velocity_mps(state.x_m, state.y_m, state.time_s)
        x += ve * dt_s
        y += vn * dt_s
    if params.drift_half_width_m > 0:
        # Always 2n draws a step, docked or not: the random stream does not depend on what happened.
        half = params.drift_half_width_m
        steps = 1 if step_period_s is None else max(1, round(dt_s / step_period_s))
        drift = random_drift_m(rng, state.n, half) if steps == 1 else summed_drift_m(rng, state.n, half, steps)
        x += drift[0]
        y += drift[1]
    docked = docked_mask.nonzero()[0]
    if docked.size:
        # Docked agents sit on their aPad: no current, no drift; they stay put while its position is unknown.
        x[docked] = state.x_m[docked]
        y[docked] = state.y_m[docked]
        if inputs.apad_ids.size:
            r = _apad_rows(inputs.apad_ids)[dock_apad[docked]]
            has = r >= 0
            x[docked[has]] = inputs.apad_x_m[r[has]]
            y[docked[has]] = inputs.apad_y_m[r[has]]

    # --- depth -------------------------------------------------------------------------------
    # ACTIVE on the seabed, FLOATING/DOCKED at the surface, DEPLETED where it stopped; in transit linear.
    if st is state.state and not trans.size and state.step_index:
        depth = state.depth_m  # no state changed and none in transit: every depth as the last step left it
    else:
        fixed = _depth_lut(params.seabed_depth_m)[st]
        depth = np.where(np.isnan(fixed), state.depth_m, fixed)
    if trans.size:  # still in transit: the timers' agents that neither arrived nor ran flat
        trans = trans[(st[trans] == SURFACING) | (st[trans] == SINKING)]
    if trans.size:
        t = timer[trans]
        up = st[trans] == SURFACING
        frac_down = np.where(
            up,
            t / max(params.surfacing_time_s, TIMER_EPS_S),
            1.0 - t / max(params.sinking_time_s, TIMER_EPS_S),
        )
        depth[trans] = params.seabed_depth_m * np.clip(frac_down, 0.0, 1.0)

    for fresh in (x, y, depth, u, st, timer, dock_apad, dock_slot, profile, held, next_wake, taken, due):
        if fresh.flags.writeable:  # ours alone (the last state's are read-only already): kept as they are
            fresh.flags.writeable = False
    new_state = FleetState.of_step(
        ids=ids,
        x_m=x,
        y_m=y,
        depth_m=depth,
        battery_frac=u,
        state=st,
        timer_s=timer,
        dock_apad=dock_apad,
        dock_slot=dock_slot,
        profile=profile,
        surface_held=held,
        next_wake_sim_s=next_wake,
        samples_taken=taken,
        samples_due=due,
        profiles=table,
        time_us=time_us,
        step_index=state.step_index + 1,
    )
    if not (applied is _NOTHING and trans_at_start == 0 and newly_depleted.size == 0 and ids.dtype == _NO_IDS.dtype):
        events = StepEvents(
            surface_accepted_ids=ids[applied.surfaced],
            surface_refused_out_of_range_ids=ids[applied.refused_range],
            surface_refused_depleted_ids=ids[applied.refused_depleted],
            ignored_command_ids=ids[applied.ignored],
            unknown_ids=applied.unknown,
            docked_ids=ids[applied.docked],
            docked_submerged_ids=ids[applied.submerged],
            released_ids=ids[applied.released],
            floating_ids=ids[floating],
            resumed_ids=ids[resumed],
            depleted_ids=ids[newly_depleted],
            surface_held_ids=ids[applied.held],
        )
    else:  # most steps: nothing happened (the same empty arrays, without eleven indexings)
        events = _NO_EVENTS
    return new_state, events


def apply_latches(state: FleetState, inputs: FleetInputs, params: FleetParams) -> FleetState:
    """The aPads' latch events of `inputs` (release, dock) alone, with no time passing: for after
    the model's last step, when an aPad still finishes a dock or an undock (a latch is a fact the
    fleet must show). A released agent starts sinking from where it is, a docked one is at the
    surface; batteries, positions and the other agents stay as the last step left them."""
    st, timer = state.state.copy(), state.timer_s.copy()
    dock_apad, dock_slot = state.dock_apad.copy(), state.dock_slot.copy()
    latches = FleetInputs(dock_ids=inputs.dock_ids, dock_apad=inputs.dock_apad, dock_slot=inputs.dock_slot,
                          release_ids=inputs.release_ids)
    applied = _apply_commands(state, latches, params, st, timer, dock_apad, dock_slot)
    depth = state.depth_m.copy()
    depth[applied.docked] = 0.0  # on the aPad (one released sinks from the surface: its depth is 0 already)
    return replace(state, state=st, timer_s=timer, dock_apad=dock_apad, dock_slot=dock_slot, depth_m=depth)


_NO_IDS: NDArray[np.uint32] = np.zeros(0, np.uint32)
_NO_IDS.flags.writeable = False
_NO_EVENTS = StepEvents(
    surface_accepted_ids=_NO_IDS, surface_refused_out_of_range_ids=_NO_IDS, surface_refused_depleted_ids=_NO_IDS,
    ignored_command_ids=_NO_IDS, unknown_ids=EMPTY_IDS, docked_ids=_NO_IDS, docked_submerged_ids=_NO_IDS,
    released_ids=_NO_IDS, floating_ids=_NO_IDS, resumed_ids=_NO_IDS, depleted_ids=_NO_IDS,
)


_IN_TRANSIT = np.zeros(N_STATES, bool)  # SURFACING or SINKING: a timer runs
_IN_TRANSIT[[SURFACING, SINKING]] = True
_IN_TRANSIT.flags.writeable = False


def _make_apad_rows(apad_ids: NDArray[np.int64]) -> NDArray[np.intp]:
    """aPad system id -> its row in the inputs' aPad arrays (-1: none)."""
    row = np.full(256, -1, np.intp)
    row[apad_ids] = np.arange(apad_ids.size)
    return row


# Made again only for another array: a quiet step's inputs are the last ones again (`FleetInputs.make`).
_apad_rows = LastMade(_make_apad_rows)


@cache
def _depth_lut(seabed_depth_m: float) -> NDArray[np.float64]:
    lut = np.full(N_STATES, np.nan)
    lut[ACTIVE] = seabed_depth_m
    lut[FLOATING] = 0.0
    lut[DOCKED] = 0.0
    lut.flags.writeable = False  # cached: shared by every step
    return lut
