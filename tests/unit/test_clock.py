"""Clocks and the scheduler: lockstep order and determinism; the wall clock really waits."""

from __future__ import annotations

import pytest

from mavlink_dialect.transport import Bell, MemoryTransport, memory_pair, ring_on
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


def test_a_flood_on_the_wall_clock_is_cut_and_counted_and_time_goes_on() -> None:
    """In the field endless arrivals are someone flooding us, not a bug: the process must live on."""
    t = [0.0]
    clock = WallClock(monotonic=lambda: t[0], wait=lambda dt: t.__setitem__(0, t[0] + dt))
    flood = CountingPoller(budget=10**9)
    clock.scheduler.add_poller(flood)
    ticks: list[int] = []
    clock.scheduler.every(0.5, ticks.append, "tick")
    t[0] += 0.6
    clock.sleep(0.0)
    assert ticks == [600_000, 600_000]  # both due runs (0 s and 0.5 s) happened in spite of the flood
    assert clock.scheduler.drains_cut >= 1 and flood.budget < 10**9


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


class FakeWall:
    """A wall clock that moves only when the clock under test waits: deterministic real time."""

    def __init__(self) -> None:
        self.now_s = 1000.0
        self.waits: list[float] = []

    def monotonic(self) -> float:
        return self.now_s

    def wait(self, dt_s: float) -> None:
        self.waits.append(dt_s)
        self.now_s += dt_s


def test_wall_clock_waits_until_each_task_is_due_and_runs_it_on_time() -> None:
    wall = FakeWall()
    clock = WallClock(monotonic=wall.monotonic, wait=wall.wait)
    ticks: list[int] = []
    clock.scheduler.every(0.05, ticks.append, "tick", start_us=clock.now_us)
    clock.sleep(0.3)
    # Microseconds are whole and the fake's floats are not: a tick may land a microsecond late.
    assert clock.time() == pytest.approx(0.3, abs=2e-6)
    assert ticks == pytest.approx([0, 50_000, 100_000, 150_000, 200_000, 250_000, 300_000], abs=2)  # each once
    assert sum(wall.waits) == pytest.approx(0.3, abs=1e-5) and len(wall.waits) <= 12  # idled, never spun


def test_wall_clock_rephases_a_task_after_a_long_stall_instead_of_a_burst() -> None:
    wall = FakeWall()
    clock = WallClock(monotonic=wall.monotonic, wait=wall.wait)
    ticks: list[int] = []
    clock.scheduler.every(0.1, ticks.append, "tick", start_us=clock.now_us)
    clock.sleep(0.15)
    wall.now_s += 30.0  # the laptop was suspended
    clock.sleep(0.05)
    assert ticks[:2] == [0, 100_000] and len(ticks) == 3  # one run after the stall, not 300


class EchoEnd:
    """A poller on one end of an in-memory pair that answers every datagram with `echoes` more."""

    def __init__(self, transport: MemoryTransport, echoes: int = 0) -> None:
        self.transport, self.echoes = transport, echoes
        self.polls: int = 0
        self.got: list[bytes] = []

    def poll(self) -> bool:
        self.polls += 1
        data = self.transport.receive()
        for d in data:
            self.got.append(d)
            if self.echoes:
                self.echoes -= 1
                self.transport.send(d + b"'")
        return bool(data)

    def fileno(self) -> int | None:
        return None

    def ring_on(self, bell: Bell) -> bool:
        return ring_on(self.transport, bell)


def test_a_drain_polls_in_memory_ends_only_after_a_delivery_and_until_none_is_left() -> None:
    clock = VirtualClock()
    a_end, b_end = memory_pair()
    a, b = EchoEnd(a_end, echoes=2), EchoEnd(b_end, echoes=3)
    clock.scheduler.add_poller(a)
    clock.scheduler.add_poller(b)
    clock.scheduler.every(1.0, lambda t: a_end.send(b"x"), "sender", 500_000)
    clock.scheduler.every(0.1, lambda t: None, "physics")  # instants that deliver nothing
    clock.sleep(2.0)
    # Each echo came back within its instant, however long the exchange ...
    assert b.got == [b"x", b"x''", b"x''''", b"x"] and a.got == [b"x'", b"x'''", b"x'''''"]
    # ... and the 19 quiet instants polled nobody: the first drain (nothing known yet), four rounds at
    # 0.5 s (the exchange) and one at 1.5 s (one delivery, no answer).
    assert a.polls == b.polls == 6


def test_one_poller_without_a_doorbell_makes_every_drain_poll() -> None:
    clock = VirtualClock()
    a_end, b_end = memory_pair()
    a, b = EchoEnd(a_end), EchoEnd(b_end)
    counting = CountingPoller(0)
    for poller in (a, b, counting):
        clock.scheduler.add_poller(poller)
    clock.scheduler.every(0.1, lambda t: None, "physics")
    clock.sleep(1.0)
    assert a.polls == counting.polls > 10
    clock.scheduler.remove_poller(counting)
    before = a.polls
    clock.sleep(1.0)
    assert a.polls - before <= 1  # the rest ring: quiet instants poll nobody again
