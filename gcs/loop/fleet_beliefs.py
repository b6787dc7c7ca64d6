"""One loop's belief of the whole fleet at once (`gcs.belief.fleet_belief`), made once per table version and instant.

The idle wait looks at the pool, and asks when it could next grow, many times at one instant (several aPads'
loops, a look after each piece of news) and at every instant something happens; each asks for every
aMussel's battery. `FleetBeliefs` makes the table's beliefs once, with numpy, and again only when a report
changed the table, time moved on or the loop sent a sleep order (its drains and anchors); a row the arrays
leave to the scalar (a docked aMussel, a real one) is asked of `FleetKnowledge.battery` when read, which reads
what the slots and the registry say now. Read-only: a cache of what the knowledge derives, nothing the loop
writes (`gcs.loop.book`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from gcs.belief.duty import OrdersSent
from gcs.belief.fleet_belief import Anchors, Believed, believed_rows
from gcs.link.apad_api import ApadApi
from missiontime import Clock
from mussel_sim.vocabulary import MusselState

Rows = tuple[NDArray[np.float64], NDArray[np.bool_]]  # (belief, exact) per table row


class FleetBeliefs:
    """Every row's belief for one loop (its own drains and sleep orders); `battery`: the scalar, for the rows
    the arrays leave to it."""

    def __init__(self, api: ApadApi, clock: Clock, orders: OrdersSent, acoustic: bool,
                 drain_per_s: Callable[[int], float], battery: Callable[[int], float]) -> None:
        self.api, self.clock, self.orders, self.acoustic = api, clock, orders, acoustic
        self.drain_per_s, self.battery = drain_per_s, battery
        self._duties: tuple[tuple[object, int], NDArray[np.float64], Anchors] | None = None
        self._rows: tuple[tuple[object, int, int, int], Rows] | None = None
        self._of: dict[tuple[MusselState, ...], Believed] = {}  # at the rows' key, selections all exact

    def drain_rows(self) -> NDArray[np.float64]:
        """Each table row's aMussel's drain per mission second (`drain_per_s`)."""
        return self._row_duties()[0]

    def _row_duties(self) -> tuple[NDArray[np.float64], Anchors]:
        """Each row's drain and anchor (`OrdersSent.changed`), made again only when the table grew (or was
        restored: its ids are another array) or a sleep order changed a duty."""
        t = self.api.mussels
        key = (t.ids, self.orders.sent)
        cached = self._duties
        if cached is None or cached[0][0] is not t.ids or cached[0][1] != key[1]:
            ids = t.ids.tolist()
            drains = np.array([self.drain_per_s(m) for m in ids], np.float64)
            anchors = Anchors.of(ids, self.orders.changed)
            cached = self._duties = key, drains, anchors
        return cached[1], cached[2]

    def rows(self) -> Rows:
        """(belief, exact) of every table row now (`believed_rows`), made once per table version and instant."""
        t = self.api.mussels
        now_us = self.clock.now_us
        key = (t.ids, t.version, now_us, self.orders.sent)
        cached = self._rows
        if cached is not None and cached[0][0] is t.ids and cached[0][1:] == key[1:]:
            return cached[1]
        drains, anchors = self._row_duties()
        made = believed_rows(t.battery_frac, t.time_us, t.state, t.simulated, now_us, drains, anchors, self.acoustic)
        self._rows, self._of = (key, made), {}
        return made

    def of(self, states: tuple[MusselState, ...]) -> Believed:
        """The aMussels last reported in one of `states`, lowest id first, as believed now."""
        belief, exact = self.rows()
        found = self._of.get(states)
        if found is not None:
            return found
        t = self.api.mussels
        wanted = np.zeros(256, bool)  # a lookup by state, as `MusselTable.select`
        wanted[[int(s) for s in states]] = True
        rows = np.flatnonzero(wanted[t.state])
        rows = rows[np.argsort(t.ids[rows], kind="stable")]
        battery = belief[rows]
        scalar = ~exact[rows]
        for k in np.flatnonzero(scalar).tolist():
            battery[k] = self.battery(int(t.ids[rows[k]]))
        found = Believed(t.ids[rows], battery, self._row_duties()[0][rows], t.time_us[rows], t.simulated[rows])
        if not scalar.any():  # the scalar's reads (slots, the registry) are not in the key: asked at each read
            self._of[states] = found
        return found

    def batteries(self, ids: list[int]) -> NDArray[np.float64]:
        """`battery` of each of `ids` (each heard), in their order."""
        belief, exact = self.rows()
        rows = self.api.mussels.rows(np.array(ids, np.int64))
        if (rows < 0).any():
            raise KeyError(ids[int(np.flatnonzero(rows < 0)[0])])  # never heard: as the table says it
        out = belief[rows]
        for k in np.flatnonzero(~exact[rows]).tolist():
            out[k] = self.battery(ids[k])
        return out
