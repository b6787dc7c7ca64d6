"""A run's figures per simulated day: exact, one row per day, kept as the run goes.

A simulated day is the aMussels' day: 86,400 s of aMussel time, which at time scale theta is
86,400 / theta s of mission time (theta 30: 48 min; a 24-h mission is 30 simulated days). A step
counts in the day its end falls in, a step ending exactly on a day's end in that day, as eq. (3)
counts a step wholly in the state it ended in (a step of several periods counts as so many steps:
the event platform's never spans a day's end). Per day: the steps, the sum over them of the active
count (so the day's mean uptime is that over steps x aMussels), how many aMussels were alive (not
DEPLETED) at the day's last step, and how many ran flat for the first time that day. Memory grows by
one row per day (a week at theta 30 is 210 rows), never per step.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from missiontime import US_PER_S

SIM_DAY_S = 86_400.0  # one day of aMussel time


def day_us(theta: float) -> int:
    """Mission microseconds of one simulated day at time scale `theta`."""
    return max(round(SIM_DAY_S * US_PER_S / theta), 1)


@dataclass
class DayLedger:
    """Per simulated day (index 0 = the first): the aggregates above. `start_us`: mission time of day 0's start."""

    day_us: int
    start_us: int = 0
    steps: list[int] = field(default_factory=list)
    active_sum: list[int] = field(default_factory=list)
    alive_end: list[int] = field(default_factory=list)
    depleted_new: list[int] = field(default_factory=list)
    end_us: list[int] = field(default_factory=list)  # mission time of the day's last step recorded

    def day_of(self, time_us: int) -> int:
        """The day a step ending at `time_us` counts in."""
        return max(time_us - self.start_us - 1, 0) // self.day_us

    def days_of(self, times_us: NDArray[np.int64]) -> NDArray[np.int64]:
        """`day_of` of many instants (an event at a day's boundary counts in the day it ends)."""
        return np.maximum(np.asarray(times_us, np.int64) - self.start_us - 1, 0) // self.day_us

    def add(self, time_us: int, active: int, alive: int, newly_depleted: int, steps: int = 1) -> None:
        """Count one step that ended at `time_us` with these counts, as `steps` steps of the model's
        period (a longer step lies within one day, its counts constant over it: the event platform's)."""
        d = self.day_of(time_us)
        while len(self.steps) <= d:  # a new day (or days without a step: a day shorter than a step)
            for column in (self.steps, self.active_sum, self.depleted_new):
                column.append(0)
            self.alive_end.append(self.alive_end[-1] if self.alive_end else alive)
            self.end_us.append(self.end_us[-1] if self.end_us else self.start_us)
        self.steps[d] += steps
        self.active_sum[d] += active * steps
        self.depleted_new[d] += newly_depleted
        self.alive_end[d] = alive
        self.end_us[d] = time_us

    def copy(self) -> DayLedger:
        return DayLedger(self.day_us, self.start_us, list(self.steps), list(self.active_sum), list(self.alive_end),
                         list(self.depleted_new), list(self.end_us))

    def uptime_pct(self, n_mussels: int) -> NDArray[np.float64]:
        """Mean uptime per day `(days,)`: eq. (3) over the day's steps and every aMussel."""
        steps = np.asarray(self.steps, np.float64)
        counted = steps * max(n_mussels, 1)
        return np.divide(100.0 * np.asarray(self.active_sum, np.float64), counted,
                         out=np.zeros(steps.size), where=counted > 0)

    def spans_s(self) -> list[tuple[float, float]]:
        """Each day's span of mission time, seconds since the start: (start, end) (the last day ends at
        its last step: a mission need not end on a day's end)."""
        out = []
        for d, end_us in enumerate(self.end_us):
            start = d * self.day_us
            full = (d + 1) * self.day_us
            out.append((start / US_PER_S, min(full, end_us - self.start_us) / US_PER_S))
        return out
