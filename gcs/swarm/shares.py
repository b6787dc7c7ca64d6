"""Several aPads sharing one fleet: who serves whom, and re-sharing when an aPad is lost or back.

`FleetShares` is the one record of it: each aMussel has an owner (the aPad whose share it is, from
`gcs.swarm.partition`) and, while an aPad is fetching or holding it, a claim. An aPad only calls
up aMussels it owns and claims first, and a claim by a live aPad is never taken away, so no two
aPads ever call up the same aMussel. `SwarmWatch` re-shares the fleet whenever the set of usable
aPads changes: an aPad is lost when it has been silent for `APAD_LOST_S` or its battery is at its
end threshold, and usable again once heard with battery to spare. The lost aPad's claims go: an
aMussel it left floating is then another aPad's to fetch (`orphans`); one docked on it stays on it,
and the accounting reports it held there.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import shapely

from apad_sitl.vocabulary import Primitive, Progress
from gcs.link.apad_api import ApadApi, Location
from gcs.link.registry import VehicleRegistry
from gcs.link.telemetry import DEG_E7
from gcs.records.events import EventLog
from gcs.swarm.partition import Partition, partition
from missiontime import US_PER_S, Clock, seconds_to_us
from missiontime.event_clock import EventClock
from mussel_sim.geo import LocalFrame
from mussel_sim.vocabulary import MusselState

APAD_LOST_S = 10.0  # an aPad silent this long is out of the sharing until heard again
# A lost aPad's claims hold this long: a called-up aMussel surfaces (up to the surfacing timeout,
# 120 s) and is docked (10 s) by its own aPad if that one comes back in time.
CLAIM_GRACE_S = 150.0
WATCH_PERIOD_S = 1.0


@dataclass
class FleetShares:
    """Owners and claims of the aMussels among the aPads (read and written by the aPads' loops
    and the watch; under `missiontime.processes` only one of them runs at a time).

    A claim lasts until its aPad releases it. An aPad found lost keeps its claims for
    `CLAIM_GRACE_S` (it may be mid-collection behind a bad link and come back); after that its
    floating aMussels are orphans, another aPad's to fetch, and the lost one, if it comes back,
    finds the claim gone and leaves that aMussel alone (the loop checks before closing in and docking).
    """

    owner: dict[int, int] = field(default_factory=dict)  # aMussel id -> aPad system id
    claims: dict[int, int] = field(default_factory=dict)  # aMussel id -> the aPad fetching or holding it
    usable: frozenset[int] = frozenset()  # aPads in the current sharing
    lost_since_us: dict[int, int] = field(default_factory=dict)  # aPad -> when it was found lost
    partition: Partition | None = None
    first: Partition | None = None  # the sharing the mission started with
    reshares: int = 0
    version: int = 0  # bumped on every change of owners or claims: news to a loop waiting on its share

    def live_claim(self, mussel: int, now_us: int) -> int | None:
        """The aPad whose claim on `mussel` holds now (a lost aPad's, within the grace)."""
        apad = self.claims.get(mussel)
        lost = self.lost_since_us.get(apad) if apad is not None else None
        if lost is not None and now_us - lost >= seconds_to_us(CLAIM_GRACE_S):
            return None
        return apad

    def serves(self, apad: int, mussel: int, now_us: int) -> bool:
        """May `apad` call this aMussel up: its share, and no live claim of another aPad on it."""
        return self.owner.get(mussel) == apad and self.live_claim(mussel, now_us) in (None, apad)

    def claim(self, apad: int, mussel: int, now_us: int) -> bool:
        if not self.serves(apad, mussel, now_us):
            return False
        self.claims[mussel] = apad
        self.version += 1
        return True

    def holds(self, apad: int, mussel: int) -> bool:
        """Whether `apad`'s claim on `mussel` still stands (not taken over while it was lost)."""
        return self.claims.get(mussel) == apad

    def release(self, apad: int, mussel: int) -> None:
        if self.claims.get(mussel) == apad:
            del self.claims[mussel]
            self.version += 1

    def reshare(self, usable: frozenset[int], new: Partition, now_us: int) -> None:
        """Take a new partition among `usable`. An aMussel claimed by a usable aPad stays that
        aPad's whatever the partition says; the claims of an aPad no longer usable are kept (for
        the grace) and the time it was lost noted."""
        for apad in self.usable - usable:
            self.lost_since_us.setdefault(apad, now_us)
        for apad in usable:
            self.lost_since_us.pop(apad, None)
        self.owner = new.owner() | {m: a for m, a in self.claims.items() if a in usable}
        self.usable, self.partition = usable, new
        if self.first is None:
            self.first = new
        self.reshares += 1
        self.version += 1

    def join(self, joiners: dict[int, int]) -> None:
        """aMussels heard for the first time (`joiners`: aMussel id -> aPad) join those aPads' shares;
        nobody else moves. The sharing the mission started with grows with them until the first re-share."""
        assert self.partition is not None  # joining needs a sharing
        old = self.partition
        grown = Partition({a: sorted(ids + [m for m, j in joiners.items() if j == a]) for a, ids in old.shares.items()},
                          old.centres)
        if self.first is self.partition:
            self.first = grown
        self.partition = grown
        self.owner |= joiners
        self.version += 1


class SwarmWatch:
    """A watch on the world's clock: re-shares the fleet when the usable aPads change."""

    def __init__(
        self, registry: VehicleRegistry, shares: FleetShares, frame: LocalFrame, apads: dict[int, float],
        events: EventLog, clock: Clock, seed: int = 0, fleet_size: int = 0,
    ) -> None:
        """`apads`: every aPad of the scenario, by system id, with its battery end threshold (V);
        `fleet_size`: the aMussels the mission expects to hear (an even share of them is the room each
        aPad has for those that join as they are heard; 0: as many as are known)."""
        self.registry, self.shares, self.frame, self.apads = registry, shares, frame, apads
        self.events, self.clock, self.seed, self.fleet_size = events, clock, seed, fleet_size
        self.on_reshare: list[Callable[[FleetShares], None]] = []
        self.retired: set[int] = set()  # aPads whose loop has ended (battery): never shared again

    def retire(self, apad: int) -> None:
        """`apad`'s loop has ended: take it out of the sharing now, for good."""
        self.retired.add(apad)
        self.check(self.clock.now_us)

    def register(self, start_us: int) -> None:
        """Every `WATCH_PERIOD_S` from `start_us`; on the event platform whenever time moves on (what it
        watches changes only at instants, and the ideal link loses no aPad)."""
        if isinstance(self.clock, EventClock):
            seen: list[tuple[int, int, int]] = []

            def on_time(now_us: int) -> None:  # looked at again only if what it reads changed (its news)
                state = (self.registry.news, self.registry.mussels.version, len(self.retired))
                if now_us >= start_us and (not seen or seen[0] != state):
                    seen[:] = [state]
                    self.check(now_us)

            self.clock.on_time(on_time)
        else:
            self.clock.scheduler.every(WATCH_PERIOD_S, self.check, "swarm.watch", start_us)

    def usable_now(self, now_us: int) -> frozenset[int]:
        out = set()
        for sysid, end_v in self.apads.items():
            if sysid in self.retired:
                continue
            view = self.registry.vehicles.get(sysid)
            if view is None or view.lat_deg is None or view.lon_deg is None:
                continue
            if self.registry.silent_us(view, now_us) > seconds_to_us(APAD_LOST_S):
                continue
            if view.battery_v is not None and view.battery_v <= end_v:
                continue
            out.add(sysid)
        return frozenset(out)

    def check(self, now_us: int) -> None:
        usable = self.usable_now(now_us)
        if not usable:
            return
        if usable == self.shares.usable:
            self.join_newcomers()
            return
        lost, back = sorted(self.shares.usable - usable), sorted(usable - self.shares.usable)
        self.reshare(usable)
        shares = self.shares.partition.shares if self.shares.partition else {}
        self.events.emit(self.clock.time(), "reshare", usable=sorted(usable), lost=lost, back=back,
                         shares={str(a): ids for a, ids in shares.items()})

    def join_newcomers(self) -> None:
        """aMussels first heard after the sharing (acoustically, in their TDMA slots; a real one as it
        comes in range) each join the share of the nearest centre with room (an even share of the
        fleet expected, or of all known if more); the shares already made stay as they are."""
        table, shares = self.registry.mussels, self.shares
        new = np.array(sorted(set(table) - shares.owner.keys()), np.int64)
        if not len(new) or shares.partition is None:
            return
        centres = shares.partition.centres
        apads = sorted(a for a in shares.usable if a in centres)
        if not apads:
            return
        counts = {a: len(shares.partition.shares.get(a, [])) for a in apads}
        known = sum(len(ids) for ids in shares.partition.shares.values()) + len(new)
        room = math.ceil(max(known, self.fleet_size) / len(apads))  # an even share of the whole fleet
        self.registry.positions_at(self.clock.now_us)
        rows = table.rows(new)
        x, y = self.frame.to_local(table.lat_e7[rows] / 1e7, table.lon_e7[rows] / 1e7)
        joiners: dict[int, int] = {}
        for m, mx, my in zip(new.tolist(), np.atleast_1d(x).tolist(), np.atleast_1d(y).tolist(), strict=True):
            open_ = [a for a in apads if counts[a] < room] or apads
            apad = min(open_, key=lambda a: (math.hypot(centres[a][0] - mx, centres[a][1] - my), a))
            joiners[m] = apad
            counts[apad] += 1
        shares.join(joiners)
        self.events.emit(self.clock.time(), "joined", shares={str(a): sorted(m for m, j in joiners.items() if j == a)
                                                              for a in apads if a in joiners.values()})
        for hook in self.on_reshare:
            hook(shares)

    def reshare(self, usable: frozenset[int]) -> None:
        """Partition every aMussel heard among `usable` (positions as last reported)."""
        table = self.registry.mussels
        self.registry.positions_at(self.clock.now_us)
        ids = np.array(sorted(table), np.int64)
        rows = table.rows(ids)
        x, y = self.frame.to_local(table.lat_e7[rows] / 1e7, table.lon_e7[rows] / 1e7)
        apads_xy = {}
        for sysid in sorted(usable):
            view = self.registry.vehicles[sysid]
            assert view.lat_deg is not None and view.lon_deg is not None  # usable: it has a position
            ax, ay = self.frame.to_local(view.lat_deg, view.lon_deg)
            apads_xy[sysid] = (float(ax), float(ay))
        self.shares.reshare(usable, partition(ids, np.column_stack([x, y]), apads_xy, seed=self.seed),
                            self.clock.now_us)
        for hook in self.on_reshare:
            hook(self.shares)


def orphans(shares: FleetShares, registry: VehicleRegistry, apad: int, now_us: int) -> list[int]:
    """aMussels of `apad`'s share floating with no live claim on them: left by an aPad that was
    lost, or one that surfaced after its own aPad had given up on it."""
    floating = registry.mussels.select((MusselState.FLOATING,))
    return [m for m in floating if shares.owner.get(m) == apad and shares.live_claim(m, now_us) is None]


def route_conflicts(api: ApadApi, apad: int, target: Location, separation_m: float) -> list[int]:
    """The other aPads within `separation_m` of the straight leg from `apad` to `target`, by where
    they are or where their Go To is taking them (distances in a local frame at `apad`)."""
    here = api.position(apad)
    frame = LocalFrame(here.lat, here.lon)
    tx, ty = frame.to_local(target.lat, target.lon)
    leg = shapely.LineString([(0.0, 0.0), (float(tx), float(ty))])
    out = []
    now_us = api.clock.now_us
    for sysid, view in sorted(api.link.vehicles.items()):
        if sysid == apad or view.lat_deg is None or view.lon_deg is None:
            continue
        points = [(view.lat_deg, view.lon_deg)]  # a silent aPad is still an obstacle where last seen
        going = view.expected
        heard = api.link.registry.silent_us(view, now_us) <= seconds_to_us(APAD_LOST_S)
        if (heard and going is not None and going.kind == Primitive.GOTO and going.matches(view.primitive)
                and view.primitive.progress == Progress.IN_PROGRESS):
            points.append((going.a / DEG_E7, going.b / DEG_E7))
        for lat, lon in points:
            x, y = frame.to_local(lat, lon)
            if leg.distance(shapely.Point(float(x), float(y))) < separation_m:
                out.append(sysid)
                break
    return out


def others_lapse_s(api: ApadApi, apad: int) -> float | None:
    """When another aPad heard now could first count as silent (`route_conflicts` then no longer counts
    where its Go To is taking it), mission s; None if none is heard."""
    now_us = api.clock.now_us
    registry = api.link.registry
    times = [registry.lapses_us(view, seconds_to_us(APAD_LOST_S)) for sysid, view in api.link.vehicles.items()
             if sysid != apad]
    ahead = [t for t in times if t is not None and t >= now_us]
    return min(ahead) / US_PER_S if ahead else None
