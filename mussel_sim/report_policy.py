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
- every publish while depleted (its last words, `comms.LAST_WORDS`, are few and must get through).

Between reports the GCS runs the battery forward in the model's steps (`gcs.mission.belief`), so it
plans on what a report every step would have said, to float rounding. Keep-alive 0: every speaking
aMussel at every publish, as before. Pure bookkeeping: the caller passes the state and the time.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from mussel_sim.vocabulary import MusselState

# A scenario's default keep-alive (`[fleet] status_keepalive_s`): five steps of the model. A lost
# report costs the GCS five seconds of foresight, not knowledge: it runs the model meanwhile.
STATUS_KEEPALIVE_S = 5.0
_NO_ROWS = np.zeros(0, np.intp)
_NO_ROWS.flags.writeable = False
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
        self.held = 0  # reports a publish left out (the GCS foresaw them): the link's saving, counted

    def again(self, rows: NDArray[np.intp]) -> None:
        """Report these at the next publish, changed or not."""
        reported = self.reported_state.copy()
        reported[rows] = NEVER
        self.reported_state = reported

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
        if not window and speaking is None and self.spoke is None and state is self.reported_state \
                and not self._depleted:  # the very state last reported (the model changed nothing): none
            self.held += state.size
            return _NO_ROWS
        if window:
            due = talking
        else:
            due = (state != self.reported_state) | (state == MusselState.DEPLETED)
            if self.spoke is not None:  # one that starts speaking again reports at once
                due |= ~self.spoke
            if talking is not None:
                due &= talking
        self.spoke = talking
        if due is None:
            self.reported_state = state  # the fleet's state arrays are read-only: kept as they are
            self._depleted = bool((state == MusselState.DEPLETED).any())
            return None
        if talking is None:  # every row is now as reported (due or unchanged): keep the state itself
            self.reported_state = state
        else:
            self.reported_state = np.where(due, state, self.reported_state)
        self._depleted = bool((self.reported_state == MusselState.DEPLETED).any())
        rows = np.flatnonzero(due)
        self.held += (state.size if speaking is None else speaking.size) - rows.size
        return rows
