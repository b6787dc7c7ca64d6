"""Several blocking scripts on one clock, one at a time, in a deterministic order."""

from __future__ import annotations

import threading

import pytest
from greenlet import greenlet

from missiontime import Clock, VirtualClock
from missiontime.processes import Processes


def _script(name: str, period_s: float, n: int, log: list[tuple[str, float]], running: list[str]) -> object:
    def body(clock: Clock) -> str:
        for _ in range(n):
            running.append(name)
            assert running.count(name) == 1 and len(running) == 1  # nobody else runs meanwhile
            log.append((name, clock.time()))
            running.remove(name)
            clock.sleep(period_s)
        return f"{name} done at {clock.time():g}"

    return body


def test_scripts_interleave_by_wake_time_and_the_world_runs_between_them() -> None:
    clock = VirtualClock()
    ticks: list[float] = []
    clock.scheduler.every(0.25, lambda now_us: ticks.append(now_us / 1e6), "world")
    log: list[tuple[str, float]] = []
    running: list[str] = []
    procs = Processes(clock)
    a = procs.spawn("a", _script("a", 1.0, 3, log, running))  # type: ignore[arg-type]
    b = procs.spawn("b", _script("b", 0.5, 4, log, running))  # type: ignore[arg-type]
    procs.run()
    assert log == [("a", 0.0), ("b", 0.0), ("b", 0.5), ("a", 1.0), ("b", 1.0), ("b", 1.5), ("a", 2.0)]
    assert (a.result, b.result) == ("a done at 3", "b done at 2")
    assert clock.time() == 3.0
    assert ticks == [0.25 * k for k in range(13)]  # the shared world ran all along, once per tick


def test_the_same_scripts_give_the_same_order_every_time() -> None:
    def once() -> list[tuple[str, float]]:
        clock = VirtualClock()
        log: list[tuple[str, float]] = []
        procs = Processes(clock)
        for name, period in (("x", 0.3), ("y", 0.2), ("z", 0.3)):
            procs.spawn(name, _script(name, period, 5, log, []))  # type: ignore[arg-type]
        procs.run()
        return log

    first = once()
    # At 0.6 all three wake: x and z went to sleep at 0.3 (in that order), y at 0.4.
    assert [n for n, t in first if t == 0.6] == ["x", "z", "y"]
    assert all(once() == first for _ in range(5))


def test_a_failing_script_stops_the_others_and_its_error_reaches_the_caller() -> None:
    clock = VirtualClock()
    unwound = threading.Event()

    def failing(c: Clock) -> None:
        c.sleep(2.0)
        raise RuntimeError("aPad 3 loop failed")

    def patient(c: Clock) -> None:
        try:
            while True:
                c.sleep(1.0)
        finally:
            unwound.set()

    procs = Processes(clock)
    procs.spawn("failing", failing)
    procs.spawn("patient", patient)
    with pytest.raises(RuntimeError, match="aPad 3 loop failed"):
        procs.run()
    assert unwound.is_set()  # the endless one was stopped at its next sleep, its finally ran
    assert clock.time() == 2.0


def test_the_worlds_error_stops_every_script_and_reaches_the_caller() -> None:
    clock = VirtualClock()

    def broken(now_us: int) -> None:
        if now_us >= 1_500_000:
            raise RuntimeError("a task failed")

    clock.scheduler.every(0.5, broken, "broken")
    unwound: list[str] = []

    def script(name: str) -> object:
        def body(c: Clock) -> None:
            try:
                while True:
                    c.sleep(1.0)
            finally:
                unwound.append(name)

        return body

    procs = Processes(clock)
    for name in ("a", "b"):
        procs.spawn(name, script(name))  # type: ignore[arg-type]
    with pytest.raises(RuntimeError, match="a task failed"):
        procs.run()
    assert sorted(unwound) == ["a", "b"]


def test_a_sleeper_that_is_next_again_runs_on_without_a_hand_over() -> None:
    clock = VirtualClock()
    running: list[str | None] = []
    switches: list[str] = []

    def quick(c: Clock) -> None:
        for _ in range(3):
            running.append(procs.current)
            c.sleep(0.1)

    def slow(c: Clock) -> None:
        c.sleep(10.0)

    procs = Processes(clock)
    procs.spawn("quick", quick)
    procs.spawn("slow", slow)
    previous = greenlet.settrace(lambda event, args: switches.append(event))
    try:
        procs.run()
    finally:
        greenlet.settrace(previous)
    assert running == ["quick"] * 3 and clock.time() == 10.0
    # run -> quick (starts, sleeps 0.1: slow is due first) -> slow (sleeps 10) -> quick, which sleeps
    # twice more without a switch (it is next again) and ends -> run -> slow, which ends -> run.
    assert len(switches) == 6


def test_a_script_catching_exception_around_its_sleep_is_still_stopped() -> None:
    clock = VirtualClock()
    tries: list[int] = []

    def failing(c: Clock) -> None:
        c.sleep(1.0)
        raise RuntimeError("boom")

    def stubborn(c: Clock) -> None:
        while len(tries) < 1000:
            try:
                c.sleep(0.5)
            except Exception:  # a broad handler must not keep a stopped script alive
                tries.append(1)

    procs = Processes(clock)
    procs.spawn("failing", failing)
    procs.spawn("stubborn", stubborn)
    with pytest.raises(RuntimeError, match="boom"):
        procs.run()
    assert tries == []


def test_a_zero_sleep_delivers_what_is_due_now() -> None:
    clock = VirtualClock()
    delivered: list[int] = []

    class Inbox:
        pending = 0

        def poll(self) -> bool:
            if self.pending:
                delivered.append(self.pending)
                self.pending = 0
                return True
            return False

        def fileno(self) -> int | None:
            return None

    inbox = Inbox()
    clock.scheduler.add_poller(inbox)

    def sender(c: Clock) -> None:
        inbox.pending = 7  # a message put on the wire ...
        c.sleep(0)  # ... is delivered by a zero sleep, as on one aPad's own clock
        assert delivered == [7]

    procs = Processes(clock)
    procs.spawn("sender", sender)
    procs.spawn("other", lambda c: c.sleep(1.0))
    procs.run()
    assert delivered == [7]
