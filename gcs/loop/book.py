"""What one aPad's loop writes down as it goes, apart from what it reads (`gcs.loop.fleet_knowledge`).

Its claims on aMussels of a shared fleet (`FleetShares`: never two aPads calling one up), where an aMussel
first found goes back to (`homes`), the sleep orders it sent (`OrdersSent`, part of the loop's status), and
the aMussels found out of the aPad's reach (each logged once). The knowledge reads all of these; the
actions and phases write them here, and nowhere else.
"""

from __future__ import annotations

from gcs.belief.duty import Duty, OrdersSent
from gcs.link.apad_api import Location
from gcs.loop.control import LoopLog
from gcs.loop.fleet_knowledge import FleetKnowledge


class LoopBook:
    """The loop's writes: claims, homes, orders sent, the unreachable. `unreachable`: those found outside
    the geofence so far."""

    def __init__(self, knows: FleetKnowledge, orders: OrdersSent, log: LoopLog) -> None:
        self.knows = knows
        self.orders = orders
        self.unreachable: set[int] = set()
        self._log = log

    def claim(self, mussel_id: int) -> bool:
        """Claim the aMussel for this aPad before calling it up (never two aPads; always, alone)."""
        knows = self.knows
        return knows.shares is None or knows.shares.claim(knows.apad_id, mussel_id, knows.clock.now_us)

    def release(self, mussel_id: int) -> None:
        """Let go of the claim: it sank, or it is another aPad's to fetch."""
        knows = self.knows
        if knows.shares is not None:
            knows.shares.release(knows.apad_id, mussel_id)

    def note_home(self, mussel_id: int) -> None:
        """A real aMussel goes back where it was first found (a simulated one: its start)."""
        knows = self.knows
        if mussel_id not in knows.homes and knows.heard(mussel_id):
            knows.homes[mussel_id] = knows.location(mussel_id)

    def ordered(self, mussel_id: int, duty: Duty) -> None:
        """A sleep order was sent: plan with it from now on (one heard was believed run down at the old duty
        until now, and at the new one from here: `OrdersSent.changed`, the anchor a belief runs on from)."""
        knows = self.knows
        if knows.heard(mussel_id):
            self.orders.changed[mussel_id] = (knows.clock.now_us, knows.battery(mussel_id))
        self.orders.duties[mussel_id] = duty
        self.orders.sent += 1

    def out_of_reach(self, mussel_id: int, where: Location) -> None:
        """Found outside the geofence (e.g. carried off by a current while it floated): one event, the
        first time, instead of trying for it again and again."""
        if mussel_id not in self.unreachable:
            self.unreachable.add(mussel_id)
            self._log("unreachable", mussel=mussel_id, lat=where.lat, lon=where.lon, why="outside the geofence")


def charging_pool(knows: FleetKnowledge, book: LoopBook) -> list[int]:
    """The charging pool as the loop takes it (`FleetKnowledge.pool`): a real aMussel's home noted as it
    is first found there, those outside the geofence written down and left out."""
    ids = knows.pool()
    for m in ids:
        if not knows.simulated(m):
            book.note_home(m)
    inside, outside = knows.within_reach(ids)
    for m in outside:
        book.out_of_reach(m, knows.location(m))
    return inside
