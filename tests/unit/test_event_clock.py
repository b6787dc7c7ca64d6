"""The event platform's clock: a wait looks only after news and at its wake time, on its own poll grid,
and so ends at the instant a lockstep wait (a look every period) ends whenever both see the same news."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from missiontime import Clock, VirtualClock
from missiontime.clocks import Declared
from missiontime.event_clock import EventClock, StalledWait, grid_at_or_after
from missiontime.processes import Processes


class Newsroom:
    """A world task that, at random instants of a seeded draw, learns something (`count` grows)."""

    def __init__(self, clock: VirtualClock, seed: int, period_s: float = 0.1, p: float = 0.02) -> None:
        self.count = 0
        self.heard_at: list[float] = []
        rng = np.random.default_rng(seed)

        def tick(now_us: int) -> None:
            if rng.random() < p:
                self.count += 1
                self.heard_at.append(now_us / 1e6)

        clock.scheduler.every(period_s, tick, "news")


def _clock(kind: type[VirtualClock], seed: int) -> tuple[VirtualClock, Newsroom]:
    clock = kind()
    news = Newsroom(clock, seed)
    if isinstance(clock, EventClock):
        clock.hears(lambda: news.count)
    return clock, news


def test_grid_is_the_first_look_of_a_lockstep_wait_at_or_after_an_instant() -> None:
    assert grid_at_or_after(0, 500, 1) == 500
    assert grid_at_or_after(0, 500, 500) == 500
    assert grid_at_or_after(0, 500, 501) == 1000
    assert grid_at_or_after(1_000, 500, 0) == 1_500  # never the start itself: a look comes after a sleep
    assert grid_at_or_after(200, 300, 1_000) == 1_100


@pytest.mark.parametrize("seed", range(6))
def test_a_wait_on_news_ends_where_lockstep_ends_with_far_fewer_looks(seed: int) -> None:
    """Wait for the third piece of news, with a declared wake time of 40 s (time alone could end it then)."""
    ends = {}
    looks = {}
    for kind in (VirtualClock, EventClock):
        clock, news = _clock(kind, seed)
        clock.sleep(0.3)  # the wait's grid starts off the news task's instants
        counted = [0]

        def look(news: Newsroom = news, clock: Clock = clock, counted: list[int] = counted) -> str | None:
            counted[0] += 1
            return "news" if news.count >= 3 else ("time" if clock.time() >= 40.0 else None)

        answer = clock.sleep_until(look, 0.5, Declared(lambda: 40.0))
        ends[kind] = (answer, clock.time())
        looks[kind] = counted[0]
    assert ends[EventClock] == ends[VirtualClock]
    assert looks[EventClock] <= 4 < looks[VirtualClock]  # three news instants and the end, at most


def test_a_wait_that_only_time_can_end_looks_once_at_its_wake_time_on_its_grid() -> None:
    clock = EventClock()
    clock.sleep(0.2)
    seen: list[float] = []

    def look() -> str | None:
        seen.append(clock.time())
        return "late" if clock.time() >= 12.34 else None

    assert clock.sleep_until(look, 0.5, Declared(lambda: 12.34)) == "late"
    assert seen == [12.7]  # 0.2 + 25 x 0.5: where lockstep's look after 12.34 s is
    assert clock.looks == 1


def test_a_wake_time_already_past_falls_back_to_looking_every_period() -> None:
    clock = EventClock()
    seen: list[float] = []

    def look() -> str | None:
        seen.append(clock.time())
        return "done" if len(seen) == 4 else None

    clock.sleep_until(look, 0.5, Declared(lambda: 0.0))  # a belief that cannot say: the past
    assert seen == [0.5, 1.0, 1.5, 2.0]


def test_a_wait_nothing_can_end_is_raised_not_a_hang() -> None:
    clock = EventClock()
    with pytest.raises(StalledWait):
        clock.sleep_until(lambda: None, 0.5)


def test_plain_sleeps_on_the_event_clock_arrive_exactly() -> None:
    clock, _ = _clock(EventClock, 1)
    clock.sleep(7.25)
    assert clock.time() == 7.25


def _two_scripts(kind: type[VirtualClock], seed: int) -> tuple[list[tuple[str, float]], int]:
    """A waiter sleeping until the shared count reaches 5, and a worker that adds to it at its own times."""
    clock = kind()
    shared = [0]
    if isinstance(clock, EventClock):
        clock.hears(lambda: shared[0])
    log: list[tuple[str, float]] = []
    rng = np.random.default_rng(seed)
    gaps = rng.uniform(0.1, 3.0, 5)
    looks = [0]

    def waiter(c: Clock) -> None:
        c.sleep(0.05)

        def look() -> str | None:
            looks[0] += 1
            return "five" if shared[0] >= 5 else None

        log.append(("waiter", c.time()))
        c.sleep_until(look, 0.5)
        log.append(("waiter woke", c.time()))

    def worker(c: Clock) -> None:
        for gap in gaps:
            c.sleep(float(gap))
            shared[0] += 1
            log.append(("worker", c.time()))

    procs = Processes(clock)
    procs.spawn("waiter", waiter)
    procs.spawn("worker", worker)
    procs.run()
    return log, looks[0]


@pytest.mark.parametrize("seed", range(5))
def test_a_script_waiting_on_another_wakes_where_lockstep_wakes_it(seed: int) -> None:
    """News from another process (not the world): the waiter looks at its next grid instant."""
    lockstep, lockstep_looks = _two_scripts(VirtualClock, seed)
    event, event_looks = _two_scripts(EventClock, seed)
    assert event == lockstep
    assert event_looks <= 5 < lockstep_looks


def test_a_looking_script_with_a_wake_time_on_processes_wakes_at_it() -> None:
    def run(kind: type[VirtualClock]) -> list[float]:
        clock = kind()
        woke: list[float] = []

        def script(c: Clock) -> None:
            c.sleep(0.3)
            c.sleep_until(lambda: "t" if c.time() >= 9.9 else None, 1.0, Declared(lambda: 9.9))
            woke.append(c.time())

        procs = Processes(clock)
        procs.spawn("a", script)
        procs.spawn("b", lambda c: c.sleep(4.0))
        procs.run()
        return woke

    assert run(EventClock) == run(VirtualClock) == [10.3]


def test_on_a_lockstep_clock_the_wake_time_changes_nothing() -> None:
    def looks(wake_at: Callable[[], float | None] | None) -> list[float]:
        clock = VirtualClock()
        seen: list[float] = []

        def look() -> str | None:
            seen.append(clock.time())
            return "x" if clock.time() >= 3 else None

        clock.sleep_until(look, 0.5, Declared(wake_at))
        return seen

    assert looks(None) == looks(lambda: 3.0) == [0.5 * k for k in range(1, 7)]
