"""Report by exception: which aMussels' AMUSSEL_STATUS a publish sends when nothing about them changed.

A resting fleet's status changes in ways the GCS can foresee: a deployed aMussel's battery runs down
by eq. (1), a docked one's charges by eq. (2), its position drifts by millimetres. Reporting every
aMussel every second (the paper's 1 Hz) then mostly repeats what the GCS's own model already says, on
the link and in the run's cost: in pool12 the fleet's status publish was a quarter of a lockstep
mission's time. So, with a keep-alive period, an aMussel reports:

- at once, at the first publish after its state changed (called up, floating, docked, released,
  resumed, depleted), or after it starts speaking again (a sleeper that woke; one back at the surface
  in an acoustic scenario);
- with every other speaking aMussel at the first publish of each keep-alive window (mission time a
  whole number of windows since 0, so a resumed mission keeps the phase, and most publishes between
  send nothing at all, which is where the time goes: a publish costs by the call, not by the row);
- every publish while depleted (its last words, `LAST_WORDS` of them, are few and must get through);
- for an aPad's charger, at the next publish after its slot latched (`ChargerReports`; the fleet also
  reports one at once as its slot lets go).

Between reports the GCS runs the battery forward in the model's steps (`gcs.belief.foresight`), so it
plans on what a report every step would have said, to float rounding. Keep-alive 0: every speaking
aMussel at every publish, as before. Pure bookkeeping: the caller passes the state and the time.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from mavlink_dialect import mavlink
from mussel_sim.memo import LastMade
from mussel_sim.vocabulary import MusselState

LATCHED = mavlink.DOCK_LATCH_STATE_LATCHED

# A scenario's default keep-alive (`[fleet] status_keepalive_s`): five steps of the model. A lost
# report costs the GCS five seconds of foresight, not knowledge: it runs the model meanwhile.
STATUS_KEEPALIVE_S = 5.0
_NO_ROWS = np.zeros(0, np.intp)
_NO_ROWS.flags.writeable = False
# The event platform's keep-alive: none (nothing periodic on an ideal link; the GCS foresees the rest).
NO_KEEPALIVE_US = 2**62
LAST_WORDS = 10  # publishes of each message a depleted aMussel still makes; 0.4 ** 10: 1e-4 all lost at 40 %
NEVER = 255  # the state of an aMussel never reported: no state has that code


class ReportByException:
    """Per aMussel, the state it last reported and whether it spoke at the last publish."""

    def __init__(self, n: int, keepalive_us: int, publish_period_us: int) -> None:
        if keepalive_us < 0:
            raise ValueError(f"keep-alive must be >= 0, got {keepalive_us} us")
        self.keepalive_us = keepalive_us
        self.publish_period_us = publish_period_us
        self.reported_state: NDArray[np.uint8] = np.full(n, NEVER, np.uint8)
        self.spoke: NDArray[np.bool_] | None = np.zeros(n, bool)  # None: every aMussel spoke
        self._depleted = False  # some aMussel's last report says DEPLETED (it reports every publish)
        self._seen: NDArray[np.uint8] | None = None  # the state array of the last publish
        self.held = 0  # reports a publish left out (the GCS foresaw them): the link's saving, counted

    def again(self, rows: NDArray[np.intp]) -> None:
        """Report these at the next publish, changed or not."""
        reported = self.reported_state.copy()
        reported[rows] = NEVER
        self.reported_state = reported
        self._seen = None  # no short cut at the next publish: these are owed

    def due(self, state: NDArray[np.uint8], speaking: NDArray[np.intp] | None,
            now_us: int) -> NDArray[np.intp] | None:
        """The rows to report now among `speaking` (None: every row; so is the answer None for all)."""
        if self.keepalive_us == 0:
            return speaking
        talking: NDArray[np.bool_] | None = None
        if speaking is not None:
            talking = np.zeros(state.size, bool)
            talking[speaking] = True
        window = now_us % self.keepalive_us < self.publish_period_us  # a window starts: everyone speaking
        if window:
            due = talking
        elif state is self._seen and not self._depleted:
            # The state of the last publish, whose changes it reported (none owed since, `again`): only
            # who starts speaking now. Mostly nobody: the publish sends nothing.
            due = None if self.spoke is None else ~self.spoke if talking is None else talking & ~self.spoke
            if due is None or not due.any():
                self.spoke = talking
                self.held += state.size if speaking is None else speaking.size
                return _NO_ROWS
        else:
            due = (state != self.reported_state) | (state == MusselState.DEPLETED)
            if self.spoke is not None:  # one that starts speaking again reports at once
                due |= ~self.spoke
            if talking is not None:
                due &= talking
        self.spoke = talking
        self._seen = state
        if due is None or talking is None:  # every row is now as reported: keep the (read-only) state itself
            self.reported_state = state
        else:
            self.reported_state = np.where(due, state, self.reported_state)
        self._depleted = bool((self.reported_state == MusselState.DEPLETED).any())
        if due is None:
            return None
        rows = np.flatnonzero(due)
        self.held += (state.size if speaking is None else speaking.size) - rows.size
        return rows


class LastWords:
    """A depleted aMussel's brown-out reports: LAST_WORDS more publishes of each message, then its radio
    is off (as its acoustic modem is, `mussel_sim.modems`): a fleet that depleted costs the link nothing."""

    def __init__(self) -> None:
        # message id -> (n,) publishes since depleted (None: nobody depleted at the last publish)
        self._counts: dict[int, NDArray[np.int64] | None] = {}
        self._depleted = LastMade(_depleted_mask)  # a state array is read-only: its mask is made once

    def powered(self, state: NDArray[np.uint8], msg_id: int, rows: NDArray[np.intp] | None) -> NDArray[np.intp] | None:
        """`rows` (None: all) but the aMussels depleted for more than LAST_WORDS publishes of `msg_id`."""
        depleted = self._depleted(state)
        if depleted is None:  # none depleted: no count runs
            self._counts[msg_id] = None
            return rows
        before = self._counts.get(msg_id)
        count = np.where(depleted, (0 if before is None else before) + 1, 0)
        self._counts[msg_id] = count
        off = count > LAST_WORDS
        if not off.any():
            return rows
        on = np.flatnonzero(~off)
        return on if rows is None else np.intersect1d(rows, on)


def _depleted_mask(state: NDArray[np.uint8]) -> NDArray[np.bool_] | None:
    """Which aMussels are depleted; None: none."""
    mask = state == MusselState.DEPLETED
    return mask if mask.any() else None


class ChargerReports:
    """An aPad's charger meters what it passes by the reports it hears while its slot holds an aMussel
    (`apad_sitl.energy`): from the first after the latch closed to the last before it opened. Reported by
    exception one may not speak for seconds, so the fleet makes both as a report every step made them:
    `slot` asks for one at the next publish after a slot latched an aMussel (once per latch), and the
    fleet reports one at once as its slot lets go (`comms`)."""

    def __init__(self, reports: ReportByException) -> None:
        self.reports = reports
        self._latched: dict[tuple[int, int], int] = {}  # (aPad, slot) -> the aMussel its latch closed on

    def slot(self, apad: int, slot: int, mussel_id: int, latch: int, row: int | None) -> None:
        """An aPad's report of a slot; `row`: the aMussel's in the fleet's state (None: not one of ours)."""
        key = (apad, slot)
        if latch != LATCHED or row is None:
            self._latched.pop(key, None)
        elif self._latched.get(key) != mussel_id:
            self._latched[key] = mussel_id
            self.reports.again(np.array([row], np.intp))
