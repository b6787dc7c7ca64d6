"""The scripted world of the loop's bench (`loop_bench`): what the loop would know of the fleet and its aPad,
set by the test as plain dicts (`World`), and `FleetKnowledge`'s reads answered from it (`ScriptedKnowledge`:
its duties, outlook and shares by the real rules, over real `LoopSettings` built from a shipped scenario the
way `gcs.mission.world` builds them).
"""

from __future__ import annotations

from collections.abc import Hashable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from apad_sitl.vocabulary import N_SLOTS, Latch
from gcs.belief.duty import Duty, OrdersSent
from gcs.belief.fleet_belief import Believed
from gcs.link.apad_api import Location
from gcs.link.telemetry import SlotView
from gcs.loop.control import LoopSettings
from gcs.loop.fleet_knowledge import READS_ALL, Reads, outlook
from gcs.mission.world import loop_settings as world_loop_settings
from gcs.scenario.reader import Scenario
from gcs.strategies import Outlook
from gcs.swarm.shares import FleetShares
from missiontime import VirtualClock
from mussel_sim.battery import ChargeProfile, charge_profile
from mussel_sim.geo import pair_distance_m
from mussel_sim.vocabulary import MusselState


def loop_settings(s: Scenario, ids: list[int]) -> LoopSettings:
    """The first aPad's loop settings, as the mission builds them (`ids`: the fleet)."""
    return world_loop_settings(s, s.apad, ids)


@dataclass
class World:
    """What the loop would know of the fleet and its aPad, set by the test."""

    position: Location  # the aPad's
    states: dict[int, MusselState] = field(default_factory=dict)
    batteries: dict[int, float] = field(default_factory=dict)
    locations: dict[int, Location] = field(default_factory=dict)
    homes: dict[int, Location] = field(default_factory=dict)  # the knowledge's `homes` (the book writes it)
    slots: dict[int, SlotView] = field(default_factory=lambda: {s: SlotView(s) for s in range(1, N_SLOTS + 1)})
    battery_v: float | None = 13.0  # the aPad's, volts (None: not heard yet)
    charging_at_home: bool = False
    link_up: bool = True
    real: set[int] = field(default_factory=set)  # real aMussels (the rest are simulated)
    surfaced: set[int] = field(default_factory=set)  # at the surface by their depth
    outside: set[int] = field(default_factory=set)  # outside the geofence
    cannot: dict[int, str] = field(default_factory=dict)  # why one cannot be collected, beyond its state
    quiet: set[int] = field(default_factory=set)  # not heard alive (believed empty, or silent too long)
    orphans: list[int] = field(default_factory=list)
    shares: FleetShares | None = None  # several aPads: a real record of owners and claims
    rises_to: dict[int, MusselState] = field(default_factory=dict)  # what a call-up makes it (else FLOATING)


class ScriptedKnowledge:
    """`FleetKnowledge`'s reads answered from a `World` (same public names and signatures; no `api`: a
    phase that reached past the knowledge to the API fails here)."""

    def __init__(self, world: World, clock: VirtualClock, settings: LoopSettings, apad_id: int,
                 orders: OrdersSent) -> None:
        self.world = world
        self.clock = clock
        self.settings = settings
        self.homes = world.homes
        self.apad_id = apad_id
        self.real = None
        self.acoustic = None
        self.orders = orders

    @property
    def shares(self) -> FleetShares | None:
        return self.world.shares

    # --- the charging pool

    def pool(self) -> list[int]:
        threshold = self.settings.mission.pool_threshold
        w = self.world
        return sorted(m for m, s in w.states.items() if s == MusselState.ACTIVE and w.batteries[m] < threshold)

    def within_reach(self, ids: list[int]) -> tuple[list[int], list[int]]:
        inside: list[int] = []
        outside: list[int] = []
        for m in ids:
            if m not in self.homes or not self.serves(m) or self.cannot_collect(m) is not None:
                continue
            (outside if m in self.world.outside else inside).append(m)
        return inside, outside

    def cannot_collect(self, mussel_id: int) -> str | None:
        state = self.state(mussel_id)
        if state == MusselState.DEPLETED:
            return "depleted"
        if state not in (MusselState.ACTIVE, MusselState.FLOATING):
            return f"it is {state.name.lower()}"
        return self.world.cannot.get(mussel_id)

    def pool_needed(self, min_pool: int) -> int:
        seabed = sum(1 for m in self.homes if self.state(m) == MusselState.ACTIVE and self.heard_alive(m))
        return max(1, min(min_pool, seabed)) if self.homes else min_pool

    def heard_alive(self, mussel_id: int) -> bool:
        return mussel_id not in self.world.quiet

    def too_late_to_call_up(self) -> bool:
        return self.settings.mission.duration_s - self.clock.time() < self.settings.call_up_margin_s

    def outlook(self) -> Outlook:
        return outlook(self.settings, self.clock.time())

    def charged(self, mussel_id: int, strategy: str) -> bool:
        return self.battery(mussel_id) >= self.settings.mission.charged_threshold

    # --- each aMussel's duty (the real rules, over the settings and the orders sent)

    def duty(self, mussel_id: int) -> Duty:
        ordered = self.orders.duties.get(mussel_id)
        return ordered if ordered is not None else self.profile_duty(mussel_id)

    def profile_duty(self, mussel_id: int) -> Duty:
        default = Duty(self.settings.mussel_discharge.rate_per_min)
        return self.settings.duties.get(mussel_id, default)

    def drain_per_s(self, mussel_id: int) -> float:
        return self.duty(mussel_id).drain_per_s(self.settings.mission.theta)

    def drain_per_min(self, mussel_id: int) -> float:
        return self.duty(mussel_id).rate_per_min

    def wake_in_s(self, mussel_id: int) -> float:
        return self.duty(mussel_id).wake_in_s(mussel_id, self.clock.time(), self.settings.mission.theta)

    def asleep(self, mussel_id: int) -> bool:
        return self.wake_in_s(mussel_id) > 0

    def call_up_wait_s(self, mussel_id: int) -> float:
        return self.settings.call_up_wait_s(self.duty(mussel_id))

    # --- slots and aMussels

    def free_slots(self) -> list[int]:
        return [s for s, view in sorted(self.world.slots.items()) if view.free]

    def slot(self, slot: int) -> SlotView:
        return self.world.slots[slot]

    def docked(self) -> dict[int, int]:
        return {s: v.mussel_id for s, v in sorted(self.world.slots.items()) if v.latch == Latch.LATCHED}

    def floating(self, mussel_id: int) -> bool:
        return self.state(mussel_id) == MusselState.FLOATING

    def state(self, mussel_id: int) -> MusselState:
        return self.world.states[mussel_id]

    def battery(self, mussel_id: int) -> float:
        return self.world.batteries[mussel_id]

    def believed(self, states: tuple[MusselState, ...]) -> Believed:
        ids = self.in_states(states)
        return Believed(np.array(ids, np.int64), self.batteries(ids),
                        np.array([self.drain_per_s(m) for m in ids], np.float64), np.zeros(len(ids), np.int64),
                        np.array([self.simulated(m) for m in ids], bool))

    def batteries(self, ids: list[int]) -> NDArray[np.float64]:
        return np.array([self.battery(m) for m in ids], np.float64)

    def charge(self, mussel_id: int) -> ChargeProfile:
        own = self.profile_duty(mussel_id).charge
        return own if own is not None else charge_profile(self.settings.mussel_charge)

    def distance_to(self, mussel_id: int) -> float:
        here, there = self.position(), self.location(mussel_id)
        return pair_distance_m(here.lat, here.lon, there.lat, there.lon)

    def position(self) -> Location:
        return self.world.position

    def location(self, mussel_id: int) -> Location:
        return self.world.locations[mussel_id]

    def heard(self, mussel_id: int) -> bool:
        return mussel_id in self.world.states

    def simulated(self, mussel_id: int) -> bool:
        return mussel_id not in self.world.real

    def at_surface(self, mussel_id: int) -> bool:
        return mussel_id in self.world.surfaced

    def in_states(self, states: tuple[MusselState, ...]) -> list[int]:
        return sorted(m for m, s in self.world.states.items() if s in states)

    def link_up(self) -> bool:
        return self.world.link_up

    def news(self, reads: Reads = READS_ALL) -> Hashable:
        """What the test set, as one value: a change of the world is news (whatever a wait `reads`)."""
        w = self.world
        return (tuple(sorted(w.states.items())), tuple(sorted(w.batteries.items())), tuple(w.slots.values()),
                w.battery_v, w.charging_at_home, w.link_up)

    def battery_v(self) -> float | None:
        return self.world.battery_v

    def charging_at_home(self) -> bool:
        return self.world.charging_at_home

    def slot_count(self) -> int:
        return len(self.world.slots)

    def latches_in_motion(self) -> list[int]:
        return [s for s, v in sorted(self.world.slots.items()) if v.latch in (Latch.CLOSING, Latch.RELEASING)]

    # --- this aPad's share (the real rules over the world's `FleetShares`)

    def orphans(self) -> list[int]:
        return list(self.world.orphans)

    def serves(self, mussel_id: int) -> bool:
        shares = self.shares
        return shares is None or shares.serves(self.apad_id, mussel_id, self.clock.now_us)

    def claimed(self, mussel_id: int) -> bool:
        return self.shares is not None and self.shares.holds(self.apad_id, mussel_id)

    def taken_over(self, mussel_id: int) -> bool:
        return self.shares is not None and not self.shares.holds(self.apad_id, mussel_id)
