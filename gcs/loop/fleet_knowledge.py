"""What one aPad's energy-sharing loop knows of the fleet, from what the GCS has heard.

`FleetKnowledge` answers with public reads: the charging pool and why an aMussel cannot be
collected now, the aPad's slots, each aMussel's state, battery and distance, this aPad's share of
the fleet with several aPads (`gcs.swarm.shares`), and the outlook a strategy plans with. It
commands and writes nothing (what the loop writes down is its book's, `gcs.loop.book`): the aPad's
actions (`gcs.loop.actions`) and the loop's phases (`gcs.loop.phases`) are built on it.
"""

from __future__ import annotations

import math
from collections.abc import Hashable
from enum import Flag, auto
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from apad_sitl.vocabulary import Latch
from gcs.acoustic_net.knowledge import UNDERWATER, age_s, believed_battery
from gcs.belief.duty import Duty, OrdersSent
from gcs.belief.fleet_belief import Believed
from gcs.belief.foresight import foreseen_battery
from gcs.belief.real_fleet import MAX_REPORT_AGE_S, RealFleet
from gcs.link.apad_api import ApadApi, Location
from gcs.link.registry import primitive_news
from gcs.link.telemetry import SlotView
from gcs.loop.control import LoopSettings
from gcs.loop.fleet_beliefs import FleetBeliefs
from gcs.results.accounting import SURFACE_DEPTH_M
from gcs.strategies import Outlook, traits
from gcs.swarm.shares import FleetShares, orphans
from missiontime import US_PER_S, Clock, seconds_to_us
from mussel_sim.battery import ChargeProfile, charge_profile, sim_minutes
from mussel_sim.geo import pair_distance_m
from mussel_sim.vocabulary import MusselState

if TYPE_CHECKING:
    from gcs.acoustic_net.network import AcousticNetwork

# An aMussel is collectable only if its battery lasts until the aPad can dock it: the trip there (at
# the aPad's speed, this much slower for acceleration and the last metres) or, if it can only be
# called up on arrival, the trip and its rise, and this margin for the close-in and the latch.
TRIP_SLOWNESS = 1.2
DOCK_MARGIN_S = 10.0
DOCK_S = 20.0  # besides surfacing, at each collection stop: closing in and latching
RELEASE_MARGIN_S = 60.0  # released early, an aMussel still has this much charge left at the end
# The aPad unheard this long: the loop starts nothing new (no call-up, no trip) until it is heard.
LINK_LOST_S = 3.0


def outlook(settings: LoopSettings, now_s: float) -> Outlook:
    """What a planning step at mission time `now_s` is told of the time left and the battery models."""
    mission = settings.mission
    return Outlook(
        time_left_s=max(mission.duration_s - now_s, 0.0),
        drain_per_s=settings.mussel_discharge.rate_per_min * sim_minutes(mission.theta, 1.0),
        charge=charge_profile(settings.mussel_charge),
        theta=mission.theta,
        speed_mps=settings.apad_speed_mps,
        stop_s=settings.mussel_surfacing_s + DOCK_S,
        charged_frac=mission.charged_threshold,
    )



class Reads(Flag):
    """What a wait's condition reads that only a message changes (`FleetKnowledge.news`): a platform that
    jumps from event to event wakes it only for news of these (`gcs.loop.wait_check` holds it to that)."""

    FLEET = auto()  # the aMussels' table: their states and batteries as reported
    SHARES = auto()  # the swarm's shares and claims
    OWN = auto()  # this aPad as heard: its mode, primitive's progress, slots, battery thresholds, link
    OTHERS = auto()  # the other aPads, likewise
    MOVES = auto()  # where the aPads are and how far their Go Tos have gone


READS_ALL = Reads.FLEET | Reads.SHARES | Reads.OWN | Reads.OTHERS | Reads.MOVES

class FleetKnowledge:
    """One aPad's view of the fleet: reads only (what the loop writes down is its `LoopBook`'s)."""

    def __init__(
        self, api: ApadApi, clock: Clock, settings: LoopSettings, homes: dict[int, Location], apad_id: int,
        shares: FleetShares | None = None, real: RealFleet | None = None,
        acoustic: AcousticNetwork | None = None, orders: OrdersSent | None = None,
    ) -> None:
        """`homes`: where each aMussel goes back to (filled in for real ones as they are first heard);
        `shares`: with several aPads, the one record of who serves which aMussel; `real`: estimates of
        real aMussels between their sparse reports; `acoustic`: the acoustic network, through which
        submerged aMussels are heard (in their TDMA slots) and called up; `orders`: the sleep orders
        sent so far (the loop's status keeps them; a restored mission's come from its checkpoint)."""
        self.api = api
        self.clock = clock
        self.settings = settings
        self.homes = homes
        self.apad_id = apad_id
        self.shares = shares
        self.real = real
        self.acoustic = acoustic
        self.orders = orders if orders is not None else OrdersSent()
        self._default_duty = Duty(settings.mussel_discharge.rate_per_min)
        self._default_charge = charge_profile(settings.mussel_charge)
        self._beliefs = FleetBeliefs(api, clock, self.orders, acoustic is not None, self.drain_per_s, self.battery)
        self._news: dict[Reads, tuple[Hashable, Hashable]] = {}  # reads -> (the registry's marks, the news)

    # --- the charging pool ----------------------------------------------------------------------

    def pool(self) -> list[int]:
        """Ids of the active aMussels below the pool threshold, lowest first, as the GCS believes them
        (`LoopBook.charging_pool` makes the charging pool of them)."""
        threshold = self.settings.mission.pool_threshold
        active = self.believed((MusselState.ACTIVE,))
        # Heard now and then (acoustic): the estimate decides, and one silent too long is not planned for.
        ids = active.ids[(active.battery < threshold) & self._alive(active)].tolist()
        if self.real is not None:  # a real one's last report may be old: its estimate decides
            real = set(self.real.ids())
            below = self.real.below(threshold, self.clock.now_us, self.drain_per_min, self.orders.changed.get)
            ids = sorted({m for m in ids if m not in real} | set(below))
        return ids

    def within_reach(self, ids: list[int]) -> tuple[list[int], list[int]]:
        """Of `ids`, (those the aPad may go to, those outside the geofence); one with no home known, of
        another aPad's share, or that cannot be collected now is in neither."""
        inside: list[int] = []
        outside: list[int] = []
        for m in ids:
            if m not in self.homes or not self.serves(m) or self.cannot_collect(m) is not None:
                continue
            (inside if self.api.inside_geofence(self.api.get_location(m)) else outside).append(m)
        return inside, outside

    def cannot_collect(self, mussel_id: int) -> str | None:
        """Why the aPad should not set off for this aMussel now, or None: it has depleted (below
        3600 mV it cannot surface), it is no longer waiting on the seabed or at the surface (e.g.
        docked elsewhere), or its battery will give out before the aPad could dock it (eq. 1 over
        the trip, its rise and the latch: it drains the same on the seabed and at the surface, and
        would be left in the water or at the surface, depleted)."""
        state = self.state(mussel_id)
        if state == MusselState.DEPLETED:
            return "depleted"
        if state not in (MusselState.ACTIVE, MusselState.FLOATING):
            return f"it is {state.name.lower()}"
        if self.real is not None:
            distance = self.distance_to(mussel_id)
            trip_s = TRIP_SLOWNESS * distance / self.settings.apad_speed_mps
            rise_s = 0.0 if state == MusselState.FLOATING else self.settings.mussel_surfacing_s
            call_up_s = 0.0 if distance <= self.settings.acoustic_range_m else trip_s
            need_s = max(trip_s, call_up_s + rise_s) + DOCK_MARGIN_S
            per_s = self.drain_per_s(mussel_id)
            battery = self.battery(mussel_id)
            if battery <= per_s * need_s:
                return f"its battery ({battery:.3f}) would give out before it could be docked ({need_s:.0f} s)"
        return None

    def pool_needed(self, min_pool: int) -> int:
        """Candidates to wait for before a collection: the scenario's `min_pool` is for the whole fleet;
        with several aPads each waits for its share's part of it (`min_pool` x share / fleet, at least
        one), or an aPad with a share of 6 would wait for 4 of its 6 as one aPad waits for 4 of 12.
        Never more than this aPad's aMussels on the seabed (at least one): a fleet smaller than
        `min_pool`, or one that depletion has thinned below it, would otherwise never be collected while
        the rest of it depleted too (issue 20: two always-on aMussels, or pool12 after a home charge)."""
        if self.shares is None or not self.shares.owner:
            need = min_pool
        else:
            share = sum(1 for owner in self.shares.owner.values() if owner == self.apad_id)
            need = max(1, math.ceil(min_pool * share / len(self.shares.owner)))
        heard = [m for m in self.homes if m in self.api.mussels and self.serves(m)]
        if not heard:  # nothing heard yet: nothing to count
            return need
        active = self.believed((MusselState.ACTIVE,))
        alive = set(active.ids[self._alive(active)].tolist())
        seabed = sum(1 for m in heard if m in alive)
        return max(1, min(need, seabed))

    def heard_alive(self, mussel_id: int) -> bool:
        """Whether the aMussel may still be alive as far as the GCS can know: always, where every aMussel
        reports over WiFi (at least every keep-alive window); in an acoustic scenario, heard within
        MAX_REPORT_AGE_S and not believed empty (a depleted aMussel under water falls silent: its
        estimate and its silence tell)."""
        view = self.api.mussels[mussel_id]
        if self.acoustic is None or not view.simulated:  # a real one's report carries its own clock: `RealFleet`
            return True
        heard_s = age_s(view, self.clock.now_us)
        return self.battery(mussel_id) > 0.0 and heard_s <= MAX_REPORT_AGE_S

    def _alive(self, b: Believed) -> NDArray[np.bool_]:
        """`heard_alive` of each of `b`."""
        if self.acoustic is None:
            return np.ones(b.ids.size, bool)
        heard_s = np.maximum(self.clock.now_us - b.heard_us, 0) / US_PER_S  # `age_s`
        return ~b.simulated | ((b.battery > 0.0) & (heard_s <= MAX_REPORT_AGE_S))

    def too_late_to_call_up(self) -> bool:
        return self.settings.mission.duration_s - self.clock.time() < self.settings.call_up_margin_s

    def outlook(self) -> Outlook:
        return outlook(self.settings, self.clock.time())

    def charged(self, mussel_id: int, strategy: str) -> bool:
        """Whether a docked aMussel may go back now: at the scenario's charged threshold, or, for a
        strategy that releases early, once it holds enough to stay active to the mission end."""
        battery = self.battery(mussel_id)
        if battery >= self.settings.mission.charged_threshold:
            return True
        if not traits(strategy).release_early:
            return False
        view = self.outlook()
        return battery >= self.drain_per_s(mussel_id) * (view.time_left_s + RELEASE_MARGIN_S)

    # --- each aMussel's duty: its drain and wake schedule --------------------------------------

    def duty(self, mussel_id: int) -> Duty:
        """What it does deployed, as known: its scenario profile or the last sleep order sent to it."""
        ordered = self.orders.duties.get(mussel_id)
        return ordered if ordered is not None else self.profile_duty(mussel_id)

    def profile_duty(self, mussel_id: int) -> Duty:
        """What its scenario profile makes it do, whatever was ordered since (a real aMussel, not in the
        scenario's fleet, takes the scenario's default)."""
        return self.settings.duties.get(mussel_id, self._default_duty)

    def drain_per_s(self, mussel_id: int) -> float:
        return self.duty(mussel_id).drain_per_s(self.settings.mission.theta)

    def drain_per_min(self, mussel_id: int) -> float:
        """Battery fraction per simulated minute deployed, by its duty (a real one's estimate runs on it)."""
        return self.duty(mussel_id).rate_per_min

    def wake_in_s(self, mussel_id: int) -> float:
        """Mission seconds until it next hears a call-up (0: awake, or always on)."""
        return self.duty(mussel_id).wake_in_s(mussel_id, self.clock.time(), self.settings.mission.theta)

    def asleep(self, mussel_id: int) -> bool:
        """Asleep now as far as its duty says (a call-up would wait for its wake: ping it first)."""
        return self.wake_in_s(mussel_id) > 0

    def call_up_wait_s(self, mussel_id: int) -> float:
        """How long a call-up may take to float it: the loop's bound, or its longest wake gap and twice
        its rise (a sleep order given during the mission may sleep longer than the scenario's profiles)."""
        return self.settings.call_up_wait_s(self.duty(mussel_id))

    # --- slots and aMussels ---------------------------------------------------------------------

    def free_slots(self) -> list[int]:
        return self.api.apad(self.apad_id).free_slots()

    def slot(self, slot: int) -> SlotView:
        return self.api.slots(self.apad_id)[slot - 1]

    def docked(self) -> dict[int, int]:
        """slot -> aMussel id of every latched slot."""
        return {s.slot: s.mussel_id for s in self.api.slots(self.apad_id) if s.latch == Latch.LATCHED}

    def floating(self, mussel_id: int) -> bool:
        return self.state(mussel_id) == MusselState.FLOATING

    def state(self, mussel_id: int) -> MusselState:
        return self.api.mussels[mussel_id].state

    def battery(self, mussel_id: int) -> float:
        """As the GCS can know it now. A simulated aMussel: its last report run forward in the model's
        steps (`foresight`: the fleet reports by exception); in an acoustic scenario, one under water
        run down since its last report (`believed_battery`). A real one out of the water: estimated since
        its report (`RealFleet`)."""
        view = self.api.mussels[mussel_id]
        if view.simulated:
            if self.acoustic is not None and view.state in UNDERWATER:
                return believed_battery(view, self.clock.now_us, self.drain_per_s(mussel_id),
                                        self.orders.changed.get(mussel_id))
            # Docked (here or on another aPad's slot): charging on, unless a slot let it go since its report.
            released_us = None
            if view.state == MusselState.DOCKED and mussel_id not in self.docked().values():
                let_go_us = self.api.link.registry.released_us.get(mussel_id)
                if let_go_us is not None and let_go_us >= view.time_us:
                    released_us = let_go_us
            return foreseen_battery(view, self.clock.now_us, self.drain_per_s(mussel_id), self.charge(mussel_id),
                                    self.settings.mission.theta, released_us, self.orders.changed.get(mussel_id))
        if self.real is not None and mussel_id in self.real.heard_us:
            on_slot = mussel_id in self.docked().values()
            return self.real.estimate(mussel_id, self.clock.now_us, on_slot, self.drain_per_min(mussel_id),
                                      self.orders.changed.get(mussel_id)).battery_frac
        return view.battery_frac

    def believed(self, states: tuple[MusselState, ...]) -> Believed:
        """The aMussels last reported in one of `states`, lowest id first, each with the battery it is believed
        to hold now (`battery`, to the bit), its drain and when it was heard: the whole fleet's beliefs at once
        (`FleetBeliefs`: numpy, made once per table version and instant)."""
        return self._beliefs.of(states)

    def batteries(self, ids: list[int]) -> NDArray[np.float64]:
        """`battery` of each of `ids`, in their order, from the fleet's beliefs at once."""
        return self._beliefs.batteries(ids)

    def charge(self, mussel_id: int) -> ChargeProfile:
        """Its charge profile on a slot: its scenario profile's (a sleep order keeps it), else the loop's."""
        own = self.profile_duty(mussel_id).charge
        return own if own is not None else self._default_charge

    def distance_to(self, mussel_id: int) -> float:
        here, there = self.api.position(self.apad_id), self.api.get_location(mussel_id)
        return pair_distance_m(here.lat, here.lon, there.lat, there.lon)

    def position(self) -> Location:
        """Where the aPad is, as last heard."""
        return self.api.position(self.apad_id)

    def location(self, mussel_id: int) -> Location:
        """Where the aMussel is, as last heard (or believed)."""
        return self.api.get_location(mussel_id)

    def heard(self, mussel_id: int) -> bool:
        return mussel_id in self.api.mussels

    def simulated(self, mussel_id: int) -> bool:
        """One of the simulated fleet (a local party: a command to it cannot be lost)."""
        return self.api.mussels[mussel_id].simulated

    def at_surface(self, mussel_id: int) -> bool:
        return self.api.mussels[mussel_id].depth_m <= SURFACE_DEPTH_M

    def in_states(self, states: tuple[MusselState, ...]) -> list[int]:
        """Ids of the aMussels last reported in one of `states`."""
        return self.api.mussels.select(states)

    def news(self, reads: Reads = READS_ALL) -> Hashable:
        """What the GCS holds that a wait can read and only a message changes, as one comparable value: the
        fleet's table (its version moves with every report), the share's claims and owners, every aPad as last
        heard (arrival stamps left out: a repeated report of the same thing is no news; its battery as the
        thresholds waits read, `VehicleRegistry.watch_battery`), and whether this aPad's link is up (it comes
        back with a heartbeat); of these, what `reads` names (a wait that reads less is woken by less).
        A wait's other changes are time's (`gcs.loop.wake_times`). Built again only when the registry's
        counters say what it reads may have changed (`VehicleRegistry.marks`): a wait asks at every instant."""
        registry = self.api.link.registry
        moves, own, others = Reads.MOVES in reads, Reads.OWN in reads, Reads.OTHERS in reads
        mark = (registry.mussels.version if Reads.FLEET in reads else None,
                (0 if self.shares is None else self.shares.version) if Reads.SHARES in reads else None,
                tuple(registry.marks(s, moves) for s in registry.vehicles if (own if s == self.apad_id else others)),
                registry.restores, self.link_up() if own else None)
        cached = self._news.get(reads)
        if cached is not None and cached[0] == mark:
            return cached[1]
        vehicles = [(s, v) for s, v in sorted(registry.vehicles.items()) if (own if s == self.apad_id else others)]
        apads = tuple((sysid, v.custom_mode, v.armed, (v.lat_deg, v.lon_deg) if moves else None,
                       registry.battery_news(sysid, v.battery_v), v.charging, v.home,
                       primitive_news(v.primitive, moves), tuple(v.slots.values()),
                       None if v.expected is None else (v.expected.kind, v.expected.a, v.expected.b, v.expected.seen))
                      for sysid, v in vehicles)
        value = (mark[0], mark[1], apads, mark[-1])
        self._news[reads] = (mark, value)
        return value

    def link_up(self) -> bool:
        """The aPad heard within `LINK_LOST_S`."""
        registry = self.api.link.registry
        return registry.silent_us(self.api.apad(self.apad_id), self.clock.now_us) <= seconds_to_us(LINK_LOST_S)

    def battery_v(self) -> float | None:
        """The aPad's battery, volts, as last heard (None: not heard yet)."""
        return self.api.battery_v(self.apad_id)

    def charging_at_home(self) -> bool:
        """The aPad reports its home charger charging it."""
        return self.api.apad(self.apad_id).charging

    def slot_count(self) -> int:
        """The aPad's slots as heard (0: not heard yet)."""
        return len(self.api.slots(self.apad_id))

    def latches_in_motion(self) -> list[int]:
        """Slots whose latch is closing or opening."""
        return [s.slot for s in self.api.slots(self.apad_id) if s.latch in (Latch.CLOSING, Latch.RELEASING)]

    # --- this aPad's share ----------------------------------------------------------------------

    def orphans(self) -> list[int]:
        """aMussels of this aPad's share floating with no live claim (`swarm.orphans`): fetch them first."""
        if self.shares is None:
            return []
        return orphans(self.shares, self.api.link.registry, self.apad_id, self.clock.now_us)

    def serves(self, mussel_id: int) -> bool:
        """Whether this aPad may call the aMussel up (always, with no other aPad)."""
        return self.shares is None or self.shares.serves(self.apad_id, mussel_id, self.clock.now_us)

    def claimed(self, mussel_id: int) -> bool:
        """Whether this aPad holds the claim on it (fetching it, or holding it on a slot); never, alone."""
        return self.shares is not None and self.shares.holds(self.apad_id, mussel_id)

    def taken_over(self, mussel_id: int) -> bool:
        """This aPad was lost long enough for another to take over its claim: leave the aMussel to
        that one (no sink: it is being fetched)."""
        return self.shares is not None and not self.shares.holds(self.apad_id, mussel_id)

