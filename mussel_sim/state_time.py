"""Where each aMussel's mission time went: the time in each `MusselState`, and when it first depleted.

Pure and clock-free: the recorder feeds it every step's end state with that step's length in
integer microseconds, so an aMussel's times add up exactly to the time recorded. A step counts
wholly in the state the aMussel ended it in, as eq. (3) counts activity.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np
from numpy.typing import NDArray

from missiontime import US_PER_S
from mussel_sim.fleet_state import DEPLETED, N_STATES
from mussel_sim.vocabulary import MusselState

NEVER = -1  # first_depleted_us of an aMussel that never depleted


@cache
def _rows(n: int) -> NDArray[np.intp]:
    """0 .. n - 1, made once per fleet size: every step indexes its rows so."""
    rows = np.arange(n)
    rows.flags.writeable = False
    return rows


@dataclass
class StateTimes:
    """state_us `(n, N_STATES)`: microseconds each aMussel spent in each state (column = MusselState).
    first_depleted_us `(n,)`: time recorded when it was first seen DEPLETED (end of that step), or NEVER.
    elapsed_us: the time recorded in all (every row of state_us sums to it)."""

    state_us: NDArray[np.int64]
    first_depleted_us: NDArray[np.int64]
    elapsed_us: int = 0

    @classmethod
    def zeros(cls, n: int) -> StateTimes:
        return cls(np.zeros((n, N_STATES), np.int64), np.full(n, NEVER, np.int64))

    def add(self, state: NDArray[np.uint8], dt_us: int) -> int:
        """Count one step of `dt_us` that ended in `state` `(n,)` (uint8 MusselState); returns how many
        depleted for the first time in it."""
        self.elapsed_us += dt_us
        self.state_us[_rows(state.size), state] += dt_us
        depleted = state == DEPLETED
        if not depleted.any():
            return 0
        newly = depleted & (self.first_depleted_us == NEVER)
        self.first_depleted_us[newly] = self.elapsed_us
        return int(np.count_nonzero(newly))

    def copy(self) -> StateTimes:
        return StateTimes(self.state_us.copy(), self.first_depleted_us.copy(), self.elapsed_us)

    def seconds(self) -> dict[str, NDArray[np.float64]]:
        """{state name in lower case: seconds `(n,)`}, every state, in MusselState order."""
        return {s.name.lower(): self.state_us[:, s] / US_PER_S for s in MusselState}

    def first_depleted_s(self) -> NDArray[np.float64]:
        """Mission seconds (since the first step) at which each first depleted `(n,)`; NaN if never."""
        return np.where(self.first_depleted_us == NEVER, np.nan, self.first_depleted_us / US_PER_S)
