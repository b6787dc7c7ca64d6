"""What the energy-sharing loop knows of the fleet, from what the GCS has heard.

The charging pool and why an aMussel cannot be collected now, the aPad's slots, each aMussel's
state, battery and distance, and this aPad's share of the fleet with several aPads
(`gcs.mission.swarm`). `LoopActions` (`gcs.mission.actions`) builds its commands on these.
"""

from __future__ import annotations

from apad_sitl.vocabulary import Latch
from gcs.api import ApadApi, Location
from gcs.link.telemetry import SlotView
from gcs.mission.control import LoopSettings
from gcs.mission.real_fleet import RealFleet
from gcs.mission.swarm import FleetShares, orphans
from gcs.records.events import EventLog
from missiontime import Clock
from mussel_sim.battery import sim_minutes
from mussel_sim.geo import distance_m
from mussel_sim.vocabulary import MusselState

# An aMussel is collectable only if its battery lasts until the aPad can dock it: the trip there (at
# the aPad's speed, this much slower for acceleration and the last metres) or, if it can only be
# called up on arrival, the trip and its rise, and this margin for the close-in and the latch.
TRIP_SLOWNESS = 1.2
DOCK_MARGIN_S = 10.0


class FleetKnowledge:
    """The loop's view of the fleet; the state it reads is set up by `LoopActions.__init__`."""

    api: ApadApi
    clock: Clock
    settings: LoopSettings
    homes: dict[int, Location]
    apad_id: int
    events: EventLog
    unreachable: set[int]
    shares: FleetShares | None
    real: RealFleet | None

    def _candidates(self) -> list[int]:
        """The charging pool: ids of active aMussels below the pool threshold, lowest first, that
        the aPad may go to (one outside the geofence, e.g. carried off by a current while it
        floated, is left out with one `unreachable` event instead of being tried again and again)."""
        threshold = self.settings.mission.pool_threshold
        ids = self.api.mussels.select((MusselState.ACTIVE,), battery_below=threshold)
        if self.real is not None:  # a real one's last report may be old: its estimate decides
            real = set(self.real.ids())
            ids = sorted({m for m in ids if m not in real} | set(self.real.below(threshold, self.clock.now_us)))
        out = []
        for m in ids:
            if not self.api.mussels[m].simulated:
                self._note_home(m)
            if m not in self.homes or not self._serves(m) or self._cannot_collect(m) is not None:
                continue
            if self.api.inside_geofence(self.api.get_location(m)):
                out.append(m)
            elif m not in self.unreachable:
                self.unreachable.add(m)
                where = self.api.get_location(m)
                self._log("unreachable", mussel=m, lat=where.lat, lon=where.lon, why="outside the geofence")
        return out

    def _cannot_collect(self, mussel_id: int) -> str | None:
        """Why the aPad should not set off for this aMussel now, or None: it has depleted (below
        3600 mV it cannot surface), it is no longer waiting on the seabed or at the surface (e.g.
        docked elsewhere), or its battery will give out before the aPad could dock it (eq. 1 over
        the trip, its rise and the latch: it drains the same on the seabed and at the surface, and
        would be left in the water or at the surface, depleted)."""
        state = self._state(mussel_id)
        if state == MusselState.DEPLETED:
            return "depleted"
        if state not in (MusselState.ACTIVE, MusselState.FLOATING):
            return f"it is {state.name.lower()}"
        if self.real is not None:
            distance = self._distance_to(mussel_id)
            trip_s = TRIP_SLOWNESS * distance / self.settings.apad_speed_mps
            rise_s = 0.0 if state == MusselState.FLOATING else self.settings.mussel_surfacing_s
            call_up_s = 0.0 if distance <= self.settings.acoustic_range_m else trip_s
            need_s = max(trip_s, call_up_s + rise_s) + DOCK_MARGIN_S
            per_s = self.real.discharge.rate_per_min * sim_minutes(self.real.theta, 1.0)
            battery = self._battery(mussel_id)
            if battery <= per_s * need_s:
                return f"its battery ({battery:.3f}) would give out before it could be docked ({need_s:.0f} s)"
        return None

    def _free_slots(self) -> list[int]:
        return self.api.apad(self.apad_id).free_slots()

    def _slot(self, slot: int) -> SlotView:
        return self.api.slots(self.apad_id)[slot - 1]

    def _docked(self) -> dict[int, int]:
        return {s.slot: s.mussel_id for s in self.api.slots(self.apad_id) if s.latch == Latch.LATCHED}

    def _floating(self, mussel_id: int) -> bool:
        return self._state(mussel_id) == MusselState.FLOATING

    def _state(self, mussel_id: int) -> MusselState:
        return self.api.mussels[mussel_id].state

    def _battery(self, mussel_id: int) -> float:
        """As last reported; for a real aMussel out of the water, estimated since (`RealFleet`)."""
        view = self.api.mussels[mussel_id]
        if self.real is not None and not view.simulated and mussel_id in self.real.heard_us:
            on_slot = mussel_id in self._docked().values()
            return self.real.estimate(mussel_id, self.clock.now_us, on_slot).battery_frac
        return view.battery_frac

    def _distance_to(self, mussel_id: int) -> float:
        here, there = self.api.position(self.apad_id), self.api.get_location(mussel_id)
        return float(distance_m(here.lat, here.lon, there.lat, there.lon))

    def _too_late_to_call_up(self) -> bool:
        return self.settings.mission.duration_s - self.clock.time() < self.settings.call_up_margin_s

    def _orphans(self) -> list[int]:
        """aMussels of this aPad's share floating with no live claim (`swarm.orphans`): fetch them first."""
        if self.shares is None:
            return []
        return orphans(self.shares, self.api.link.registry, self.apad_id, self.clock.now_us)

    def _serves(self, mussel_id: int) -> bool:
        """Whether this aPad may call the aMussel up (always, with no other aPad)."""
        return self.shares is None or self.shares.serves(self.apad_id, mussel_id, self.clock.now_us)

    def _taken_over(self, mussel_id: int) -> bool:
        """This aPad was lost long enough for another to take over its claim: leave the aMussel to
        that one (no sink: it is being fetched). Logged."""
        if self.shares is None or self.shares.holds(self.apad_id, mussel_id):
            return False
        self._log("skip", mussel=mussel_id, why="taken over by another aPad while this one was unheard")
        return True

    def _note_home(self, mussel_id: int) -> None:
        """A real aMussel goes back where it was first found (a simulated one: its start)."""
        if mussel_id not in self.homes and mussel_id in self.api.mussels:
            self.homes[mussel_id] = self.api.get_location(mussel_id)

    def _release(self, mussel_id: int) -> None:
        if self.shares is not None:
            self.shares.release(self.apad_id, mussel_id)

    def _log(self, kind: str, **fields: object) -> None:
        if self.shares is not None:
            fields = {"apad": self.apad_id, **fields}
        self.events.emit(self.clock.time(), kind, **fields)
