"""Discrete-event time: the event platform's clock (gcs.mission.platform).

On the event platform the world's tasks are sparse (no heartbeats, no periodic streams, models stepped
only when they change), so moving the clock is already a jump from one task to the next, as in
lockstep's `VirtualClock`. What differs is waiting. A lockstep wait looks at every poll period (the
field's sleep loop, the reference); here a wait looks only where its answer could have changed:

- after news: an instant at which the GCS heard something (`news`: counters the world hands in with
  `hears`, a table's version, a share's), and
- at its wake time: the first instant time alone could settle it (the wait's own declaration,
  `gcs.loop.wake_times`, its deadline, the mission's end).

Both are put on the wait's own poll grid (start + k period, the instants lockstep would look at), so a
wait ends at the instant lockstep's would whenever both see the same news: the event platform skips the
looks that could not have answered, it does not move the others. A wake time already past (a belief
that cannot say) falls back to the next grid instant: lockstep's polling, never a missed answer.

What lockstep samples every second (where an aPad's time went, its track) is a piecewise-constant
function of what the GCS knows, which changes only at instants: here it is integrated when time moves
on (`on_time`), over the stretch since, at no cost in between.

Bounded: a wait with nothing left to wake it (no task due, no wake time) is a bug, raised as
`StalledWait`, not a hang.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from typing import TypeVar

from missiontime.clocks import Declared, Scheduler, VirtualClock, seconds_to_us

T = TypeVar("T")


class StalledWait(RuntimeError):
    """A wait that nothing can end: no task is due and it named no wake time."""


def grid_at_or_after(start_us: int, period_us: int, t_us: int) -> int:
    """The first instant start + k period (k >= 1) at or after `t_us`: where a lockstep wait would look."""
    k = max(-(-(t_us - start_us) // period_us), 1)
    return start_us + k * period_us


class EventClock(VirtualClock):
    """`VirtualClock` whose waits look at news and at their wake time (module docstring)."""

    def __init__(self, scheduler: Scheduler | None = None, start_us: int = 0) -> None:
        super().__init__(scheduler, start_us)
        self._sources: list[Callable[[], int]] = []
        self._on_time: list[Callable[[int], None]] = []
        self.looks = 0  # looks taken by waits (bench/platforms.py: what skipping them saved)

    def on_time(self, hook: Callable[[int], None]) -> None:
        """Call `hook(t_us)` whenever time moves on to `t_us`, before anything at `t_us` runs: what held
        since the last move held all along (nothing changes between instants)."""
        self._on_time.append(hook)

    def moving_to(self, t_us: int) -> None:
        if t_us > self.now_us:
            for hook in self._on_time:
                hook(t_us)

    def hears(self, source: Callable[[], int]) -> None:
        """Count `source` (a counter that only grows) as news: it moves when the GCS learns something."""
        self._sources.append(source)

    def news(self) -> int:
        return sum(source() for source in self._sources)

    def advance_until_news(self, target_us: int | None) -> bool:
        """Run the world instant by instant up to `target_us` (None: unbounded), stopping after the first
        instant that brought news; True if one did (the clock is then at it), else the clock is at `target_us`."""
        sched, mark = self.scheduler, self.news()
        sched.now_us = self.now_us
        sched.drain()
        if self.news() != mark:
            return True
        while self.run_next(target_us):
            if self.news() != mark:
                return True
        if target_us is None:
            raise StalledWait("event platform: a wait with nothing left to happen and no wake time")
        self.advance_to(target_us)
        return self.news() != mark

    def sleep_until(self, look: Callable[[], T | None], period_s: float, declared: Declared | None = None) -> T:
        waiting = Waiting(self, period_s, declared)
        while True:
            wake = waiting.wake_us()
            if self.advance_until_news(wake):
                if not waiting.news_for_it() and (wake is None or self.now_us < wake):
                    continue  # heard, but nothing this wait reads
                self.advance_to(waiting.look_at(self.now_us))  # news: seen at the next look
            waiting.looks()
            answer = look()
            if answer is not None:
                return answer


class Waiting:
    """One wait on an `EventClock`: its grid of looks, its declaration, what it had heard at its last look.

    Its wake time is asked again only after news it reads, or once passed: a declaration reads what the GCS
    knows, and between news its beliefs run on as they were foreseen (the instant it named stands)."""

    def __init__(self, clock: EventClock, period_s: float, declared: Declared | None) -> None:
        self.clock = clock
        self.start_us = clock.now_us
        self.period_us = max(seconds_to_us(period_s), 1)
        self.declared = declared or Declared()
        self._heard = self._news()
        self._wake: tuple[Hashable, int | None] | None = None

    def _news(self) -> Hashable:
        return self.declared.news() if self.declared.news is not None else self.clock.news()

    def news_for_it(self) -> bool:
        """Whether what it reads changed since its last look."""
        return self._news() != self._heard

    def looks(self) -> None:
        self._heard = self._news()
        self.clock.looks += 1

    def look_at(self, t_us: int) -> int:
        """Its look at or after `t_us`: on its grid."""
        return grid_at_or_after(self.start_us, self.period_us, t_us)

    def wake_us(self) -> int | None:
        """Where it looks next by time alone: its wake time on its grid (at least the next grid instant after
        now), or None when only news can end it."""
        news, now = self._news(), self.clock.now_us
        if self._wake is None or self._wake[0] != news or (self._wake[1] is not None and self._wake[1] <= now):
            wake_at = self.declared.wake_at
            wake_s = wake_at() if wake_at is not None else None
            at = None if wake_s is None else self.look_at(max(seconds_to_us(wake_s), now + 1))
            self._wake = (news, at)
        return self._wake[1]
