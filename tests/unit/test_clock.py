"""Clocks and the scheduler: lockstep order and determinism; the wall clock really waits."""

from __future__ import annotations

import itertools
import time

import pytest

from missiontime import Scheduler, VirtualClock, WallClock


class CountingPoller:
    def __init__(self, budget: int) -> None:
        self.budget = budget
        self.polls = 0

    def poll(self) -> bool:
        self.polls += 1
        if self.budget > 0:
            self.budget -= 1
            return True
        return False

    def fileno(self) -> int | None:
        return None


def test_virtual_sleep_runs_tasks_at_their_mission_times_in_order() -> None:
    clock = VirtualClock()
    log: list[tuple[str, int]] = []
    clock.scheduler.every(1.0, lambda t: log.append(("1Hz", t)), "a")
    clock.scheduler.every(0.5, lambda t: log.append(("2Hz", t)), "b")
    clock.sleep(1.0)
    assert log == [("1Hz", 0), ("2Hz", 0), ("2Hz", 500_000), ("1Hz", 1_000_000), ("2Hz", 1_000_000)]
    assert clock.now_us == 1_000_000


def test_task_sees_its_own_time_and_clock_ends_at_target() -> None:
    clock = VirtualClock(start_us=250)
    seen: list[int] = []
    clock.scheduler.every(0.3, seen.append, "t", start_us=250)
    clock.sleep(1.0)
    assert seen == [250, 300_250, 600_250, 900_250]
    assert clock.time() == pytest.approx(1.00025)


def test_pollers_are_drained_until_quiet_after_each_task() -> None:
    clock = VirtualClock()
    poller = CountingPoller(budget=5)
    clock.scheduler.add_poller(poller)
    clock.sleep(0)
    assert poller.budget == 0  # every message delivered before sleep returned


def test_a_livelock_is_reported_not_hung() -> None:
    clock = VirtualClock()
    clock.scheduler.add_poller(CountingPoller(budget=10**9))
    with pytest.raises(RuntimeError, match="livelock"):
        clock.sleep(0)


def test_zero_period_is_refused() -> None:
    with pytest.raises(ValueError, match="period must be positive"):
        Scheduler().every(0, lambda t: None, "bad")


def test_same_setup_gives_the_same_trace() -> None:
    def trace() -> list[tuple[str, int]]:
        clock = VirtualClock()
        out: list[tuple[str, int]] = []
        for name, period in (("x", 0.1), ("y", 0.25), ("z", 1.0)):
            clock.scheduler.every(period, lambda t, n=name: out.append((n, t)), name)
        clock.sleep(3.0)
        return out

    assert trace() == trace()


def test_wall_clock_sleeps_in_real_time_and_runs_due_tasks() -> None:
    clock = WallClock()
    ticks: list[int] = []
    clock.scheduler.every(0.05, ticks.append, "tick", start_us=clock.now_us)
    start = time.monotonic()
    clock.sleep(0.3)
    elapsed = time.monotonic() - start
    assert 0.29 <= elapsed < 0.6
    assert 5 <= len(ticks) <= 8
    # Tasks see the real time they ran at: close to, never before, their period.
    assert all(45_000 <= b - a <= 80_000 for a, b in itertools.pairwise(ticks))
