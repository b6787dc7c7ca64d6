"""The fleet step's sleeping aMussels: sleep orders, call-ups held till a wake, samples, who is awake.

Pure helpers of `mussel_sim.fleet.step` (and of the comms runner's publishing), vectorised over the
aMussels on a wake schedule; nothing here runs for a fleet whose aMussels are all always on.

Semantics (`docs/long_term.md`):

- A sleep order replaces the aMussel's profile by the same profile under the order
  (`BehaviourProfile.ordered`: the order's duty-cycle discharge and wake schedule, its charge kept),
  whatever its state; the last order of a step wins.
- A sleeping aMussel stays ACTIVE on the seabed: it monitors on its schedule and earns uptime.
- A SURFACE command that reaches an ACTIVE aMussel asleep (not awake at any time of the step) is held
  and taken in the step of its next wake (range check then, with the aPads' positions then). A SINK
  cancels a held call-up; docking or depleting clears it. `FleetInputs.wake_ids` (the acoustic
  wake-up ping, to come) wakes an aMussel at once: its held call-up is taken in that step.
- Each wake of its schedule is a sample scheduled; one at which it is ACTIVE (by its state at the end
  of that step, as eq. (3) counts uptime) is a sample taken.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mussel_sim.behaviour import BEHAVIOURS, MAX_TABLE, ProfileTable
from mussel_sim.fleet_state import ACTIVE, FleetInputs, FleetState
from mussel_sim.memo import LastMade
from mussel_sim.wake import next_wake_sim_s, phase, sim_s

# A wake this close after the step's end (relative) is looked at in the step: never missed to rounding.
WAKE_EPS = 1e-9


def sleeping_fleet(table: ProfileTable, profile: NDArray[np.uint16]) -> bool:
    """Whether any aMussel may be on a wake schedule: False for the always-on fleet (everyone on the
    first profile, which has none), decided without a gather, and once per profile array (a state's is
    read-only, and the steps pass it on until a sleep order makes another)."""
    return (_any_scheduled if profile.flags.writeable else _any_scheduled_once)(table, profile)


def _any_scheduled(table: ProfileTable, profile: NDArray[np.uint16]) -> bool:
    return bool(table.scheduled[0] or profile.any())


_any_scheduled_once = LastMade(_any_scheduled)


def apply_orders(
    state: FleetState, inputs: FleetInputs, table: ProfileTable, profile: NDArray[np.uint16], theta: float
) -> tuple[ProfileTable, NDArray[np.uint16], NDArray[np.float64], NDArray[np.int64]]:
    """The step's sleep orders on (table, profile): a new profile array, the table extended by the
    ordered profiles (compacted when it grows past `MAX_TABLE`), the next wakes under the new
    schedules (the first after the step's start), and the ids no aMussel has."""
    idx, known = state.index_of(inputs.sleep_ids)
    profile = profile.copy()
    for k, interval, awake in zip(idx[known].tolist(), inputs.sleep_interval_s[known].tolist(),
                                  inputs.sleep_awake_s[known].tolist(), strict=True):  # per order, a handful
        table, profile[k] = table.with_profile(table.profiles[int(profile[k])].ordered(interval, awake))
    if len(table) > MAX_TABLE:
        table, profile = table.compacted(profile, len(BEHAVIOURS))
    ordered = np.unique(idx[known])
    next_wake = state.next_wake_sim_s.copy()
    next_wake[ordered] = next_wake_sim_s(state.ids[ordered], table.interval_s[profile[ordered]],
                                         sim_s(state.time_us, theta))
    return table, profile, next_wake, inputs.sleep_ids[~known]


@dataclass
class Sleepers:
    """One step of a fleet with sleeping aMussels, over its simulated time (t0, t1]: the ids,
    profiles, next wakes (advanced past t1) and held call-ups (a working copy, changed in place), and
    which aMussels woke in the step, how many times."""

    ids: NDArray[np.uint32]
    table: ProfileTable
    profile: NDArray[np.uint16]
    next_wake: NDArray[np.float64]
    held: NDArray[np.bool_]
    t0_sim_s: float
    t1_sim_s: float
    woke: NDArray[np.intp]
    wakes: NDArray[np.int64]
    held_changed: bool = False

    @classmethod
    def of(cls, state: FleetState, table: ProfileTable, profile: NDArray[np.uint16],
           next_wake: NDArray[np.float64], theta: float, t1_us: int) -> Sleepers | None:
        """None for the always-on fleet; else the step with each wake of (t0, t1] found."""
        if not sleeping_fleet(table, profile):
            return None
        t0, t1 = sim_s(state.time_us, theta), sim_s(t1_us, theta)
        woke = (next_wake <= t1 + WAKE_EPS * max(abs(t1), 1.0)).nonzero()[0]
        wakes = np.zeros(woke.shape, np.int64)
        if woke.size:  # usually one or two: `wake.wake_index` and `wake.next_wake_sim_s`, inlined
            interval, ph = table.interval_s[profile[woke]], phase(state.ids[woke])
            later = np.floor(t1 / interval - ph)
            wakes = (later - np.floor(t0 / interval - ph)).astype(np.int64)
            next_wake = next_wake.copy()
            next_wake[woke] = (later + 1.0 + ph) * interval
            if not wakes.all():  # looked at for rounding's sake, no wake after all
                woke, wakes = woke[wakes > 0], wakes[wakes > 0]
        return cls(state.ids, table, profile, next_wake, state.surface_held, t0, t1, woke, wakes)

    def any_held_awake(self) -> bool:
        """Whether a held call-up is let go in this step: its aMussel awake at some time of it (a
        sleeper's call-up waits for minutes of steps in which nothing is to be done for it)."""
        held = np.flatnonzero(self.held)
        return bool(held.size) and bool(self.awake(held).any())

    def _write(self) -> NDArray[np.bool_]:
        if not self.held_changed:
            self.held, self.held_changed = self.held.copy(), True
        return self.held

    def awake(self, idx: NDArray[np.intp]) -> NDArray[np.bool_]:
        """Whether each of `idx` is awake at some time of the step: its latest wake at or before t1
        lasts past t0 (always on: next wake +inf, always awake)."""
        p = self.profile[idx]
        latest = self.next_wake[idx] - self.table.interval_s[p]
        return np.asarray(latest + self.table.awake_s[p] > self.t0_sim_s)

    def hold_asleep(self, asked: NDArray[np.intp], st: NDArray[np.uint8]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        """Of the aMussels asked to surface: (those to surface now, those held for their wake)."""
        asleep = np.zeros(asked.shape, bool)
        active = st[asked] == ACTIVE
        if active.any():
            asleep[active] = ~self.awake(asked[active])
        held = asked[asleep]
        if held.size:
            self._write()[held] = True
        return asked[~asleep], held

    def clear(self, idx: NDArray[np.intp]) -> None:
        """No call-up held for these any more (sunk, docked, depleted)."""
        if idx.size and self.held[idx].any():
            self._write()[idx] = False

    def awoken(self, st: NDArray[np.uint8], woken_ids: NDArray[np.int64]) -> NDArray[np.intp]:
        """The held ones awake in this step (their wake came, a ping woke them, an order put them
        always on): their call-ups are let go, and those still ACTIVE are returned to surface now."""
        held = np.flatnonzero(self.held)
        if not held.size:
            return held
        up = self.awake(held)
        if woken_ids.size:
            up |= np.isin(self.ids[held].astype(np.int64), woken_ids)
        go = held[up]
        if go.size:
            self._write()[go] = False
        return go[st[go] == ACTIVE]

    def samples(self, st: NDArray[np.uint8], taken: NDArray[np.int64],
                due: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """The sample counters after this step: each wake of the step is due, and taken if ACTIVE at its end."""
        if not self.woke.size:
            return taken, due
        due = due.copy()
        due[self.woke] += self.wakes
        active = st[self.woke] == ACTIVE
        if active.any():
            taken = taken.copy()
            taken[self.woke[active]] += self.wakes[active]
        return taken, due


def publish_rows(state: FleetState, theta: float, since_us: int | None, now_us: int) -> NDArray[np.intp] | None:
    """The aMussels that report at a publish at `now_us` (the last one at `since_us`): all but those
    ACTIVE on a schedule that were asleep all the time in between (a sleeping aMussel speaks only when
    it is awake). None: every one (none sleeps, or the first publish)."""
    if since_us is None or not sleeping_fleet(state.profiles, state.profile):
        return None
    quiet = (state.state == ACTIVE) & (state.next_wake_sim_s < np.inf)
    idx = np.flatnonzero(quiet)
    if idx.size:
        p, t = state.profile[idx], state.profiles
        latest = state.next_wake_sim_s[idx] - t.interval_s[p]  # the state's: at or before now
        quiet[idx] = latest + t.awake_s[p] <= sim_s(since_us, theta)
    return np.flatnonzero(~quiet)
