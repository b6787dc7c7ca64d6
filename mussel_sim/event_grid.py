"""When the fleet's model steps on the event platform: instants of lockstep's step grid, as few as exact.

Lockstep steps the model at `origin_us + k * period_us` (k >= 1) up to the mission's end. The event
platform steps it at some of those instants only (`FleetRunner.register(..., events=True)`), each step
covering the periods since the last one, and the next instant is the earliest of

- the end of the periods the model may take at once with no input (`next_change.steps_at_once`);
- the last instant of the recorder's simulated day (`DayLedger`: a step counts in the day its end falls
  in, so a longer step never spans a day's end and the per-day figures stay exact);
- the mission's last step instant (`end_us`);
- the first instant after an input arrived (`after_us`): lockstep steps before it delivers an
  instant's messages, so what arrives at t is taken at the first step instant after t.

Pure arithmetic on integer microseconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from mussel_sim.day_ledger import DayLedger


@dataclass(frozen=True)
class EventGrid:
    origin_us: int  # the grid's instant 0 (the mission's start, or a resumed state's time)
    period_us: int
    end_us: int | None = None  # no step instant after this

    def floor_us(self, now_us: int) -> int:
        """The last grid instant at or before `now_us` (the origin at the latest), not past the end:
        where lockstep's model is at `now_us`."""
        k = max(now_us - self.origin_us, 0) // self.period_us
        t = self.origin_us + k * self.period_us
        return t if self.end_us is None else min(t, self.last_us())

    def after_us(self, now_us: int) -> int:
        """The first grid instant after `now_us` (past the end too: a latch after it still applies)."""
        return self.origin_us + (max(now_us - self.origin_us, -1) // self.period_us + 1) * self.period_us

    def last_us(self) -> int:
        """The last step instant (unbounded without an end)."""
        if self.end_us is None:
            return 2**62
        return self.origin_us + max(self.end_us - self.origin_us, 0) // self.period_us * self.period_us

    def next_step_us(self, time_us: int, at_once: float, days: DayLedger | None) -> int | None:
        """The next step instant after the model's state at `time_us` (a grid instant) that may take
        `at_once` periods in one (`next_change.steps_at_once`; at least one is taken), or None past the end."""
        periods = 1 if at_once < 1 else int(min(at_once, 2**40)) if math.isfinite(at_once) else 2**40
        t = time_us + periods * self.period_us
        if days is not None:  # not past the end of the day the step's first period counts in
            d = days.day_of(time_us + self.period_us)
            day_end = days.start_us + (d + 1) * days.day_us
            t = min(t, time_us + max((day_end - time_us) // self.period_us, 1) * self.period_us)
        if time_us + self.period_us > self.last_us():
            return None
        return min(t, self.last_us())
