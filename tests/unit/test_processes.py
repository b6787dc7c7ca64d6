"""Several blocking scripts on one clock, one at a time, in a deterministic order, each on a thread
of its own (a real C stack: nothing that walks the stack can run off it, issue 19)."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import threading
from collections.abc import Callable, Iterator

import numpy as np
import pytest

from missiontime import Clock, VirtualClock
from missiontime.processes import Processes


@pytest.fixture(autouse=True)
def every_thread_joined() -> Iterator[None]:
    """Whatever a test's `run` did (returned or raised), none of its threads outlives it."""
    before = threading.active_count()
    yield
    assert threading.active_count() == before


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

    def quick(c: Clock) -> None:
        for _ in range(3):
            running.append(procs.current)
            c.sleep(0.1)

    def slow(c: Clock) -> None:
        c.sleep(10.0)

    procs = Processes(clock)
    procs.spawn("quick", quick)
    procs.spawn("slow", slow)
    procs.run()
    assert running == ["quick"] * 3 and clock.time() == 10.0
    # run -> quick (starts, sleeps 0.1: slow is due first) -> slow (sleeps 10) -> quick, which sleeps
    # twice more without a hand-over (it is next again) and ends -> slow, which ends -> run.
    assert procs.hand_overs == 5
    assert procs.current is None


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


def test_same_instant_wakes_resume_in_the_order_they_went_to_sleep() -> None:
    clock = VirtualClock()
    log: list[str] = []

    def script(name: str, sleeps: list[float]) -> object:
        def body(c: Clock) -> None:
            for dt in sleeps:
                log.append(f"{name}@{c.time():g}")
                c.sleep(dt)
            log.append(f"{name}@{c.time():g}")

        return body

    procs = Processes(clock)
    procs.spawn("a", script("a", [0.0, 1.0]))  # type: ignore[arg-type]  # a zero sleep goes behind b and c
    procs.spawn("b", script("b", [1.0]))  # type: ignore[arg-type]
    procs.spawn("c", script("c", [0.5, 0.5]))  # type: ignore[arg-type]
    procs.run()
    # At 0: spawn order, then a again (it slept last). At 1: b slept at 0, c at 0.5, a at 0 after b.
    assert log == ["a@0", "b@0", "c@0", "a@0", "c@0.5", "b@1", "a@1", "c@1"]


def test_each_script_runs_on_a_thread_of_its_own_never_two_at_once() -> None:
    clock = VirtualClock()
    threads: dict[str, set[int]] = {}
    running: list[str] = []

    def script(name: str) -> object:
        def body(c: Clock) -> None:
            for _ in range(20):
                running.append(name)
                assert running == [name]
                threads.setdefault(name, set()).add(threading.get_ident())
                running.remove(name)
                c.sleep(0.1 if name != "b" else 0.15)

        return body

    procs = Processes(clock)
    for name in "abc":
        procs.spawn(name, script(name))  # type: ignore[arg-type]
    procs.run()
    assert all(len(ids) == 1 for ids in threads.values())  # always the same thread for a script ...
    idents = {next(iter(ids)) for ids in threads.values()}
    assert len(idents) == 3 and threading.get_ident() not in idents  # ... its own, not the caller's


def test_scripts_that_never_sleep_run_one_after_the_other() -> None:
    clock = VirtualClock()
    order: list[str] = []
    def script(name: str) -> Callable[[Clock], str]:
        def body(c: Clock) -> str:
            order.append(name)
            return name

        return body

    procs = Processes(clock)
    handles = [procs.spawn(name, script(name)) for name in "abc"]
    procs.run()
    assert order == ["a", "b", "c"] and [h.result for h in handles] == ["a", "b", "c"]
    assert clock.time() == 0.0


def test_one_script_only_and_none_at_all() -> None:
    clock = VirtualClock()
    def only(c: Clock) -> float:
        for _ in range(4):
            c.sleep(0.5)
        return c.time()

    procs = Processes(clock)
    one = procs.spawn("only", only)
    procs.run()
    assert one.result == 2.0 and procs.hand_overs == 2  # run -> only -> run: its sleeps hand over nothing
    Processes(clock).run()  # nothing spawned: nothing to do


def test_a_script_failing_at_once_stops_those_not_started_yet_and_their_finally_blocks_run() -> None:
    clock = VirtualClock()
    started: list[str] = []
    unwound: list[str] = []

    def script(name: str) -> object:
        def body(c: Clock) -> None:
            started.append(name)
            try:
                if name == "a":
                    raise ValueError("bad config")
                c.sleep(1.0)
            finally:
                unwound.append(name)

        return body

    procs = Processes(clock)
    for name in "abc":
        procs.spawn(name, script(name))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="bad config"):
        procs.run()
    assert started == ["a"] and unwound == ["a"]  # b and c were stopped before they began


def test_stopped_scripts_unwind_in_their_own_threads_and_may_not_sleep_again() -> None:
    clock = VirtualClock()
    unwound: list[tuple[str, float]] = []

    def failing(c: Clock) -> None:
        c.sleep(3.0)
        raise RuntimeError("aPad 2 lost")

    def polite(c: Clock) -> None:
        try:
            while True:
                c.sleep(1.0)
        finally:
            unwound.append(("polite", c.time()))
            with pytest.raises(BaseException, match="polite"):  # ProcessStopped: no more sleeping
                c.sleep(1.0)

    procs = Processes(clock)
    procs.spawn("polite", polite)
    procs.spawn("failing", failing)
    with pytest.raises(RuntimeError, match="aPad 2 lost"):
        procs.run()
    assert unwound == [("polite", 3.0)]  # stopped at its wake at 3 s, after the failure, the clock still


def test_large_numpy_temporaries_in_several_scripts_at_once() -> None:
    """Issue 19: numpy elides a temporary over 256 KiB (`(x + x) + x` reuses the buffer of `x + x`)
    after walking the C stack with glibc's `backtrace()`. On greenlets' switched stacks that walk ran
    off the stack (this test died of a segmentation fault on them); on threads it cannot."""
    clock = VirtualClock()
    x = np.ones(1 << 19)  # 4 MiB
    sums: list[float] = []

    def deep(n: int, c: Clock, period_s: float) -> None:
        if n:
            deep(n - 1, c, period_s)
            return
        sums.append(float(((x + x) + x)[-1]))
        c.sleep(period_s)

    def script(k: int) -> object:
        def body(c: Clock) -> None:
            for i in range(60):
                deep((i * 7 + k * 3) % 40, c, 0.1 * (k + 1))

        return body

    procs = Processes(clock)
    for k in range(5):
        procs.spawn(f"apad{k + 1}", script(k))  # type: ignore[arg-type]
    procs.run()
    assert sums == [3.0] * 300


CTRL_C = """
import os, signal, sys, threading, time
from missiontime import VirtualClock
from missiontime.processes import Processes

# A suite started in the background (`make test &`) hands its processes SIGINT ignored, and Python
# keeps an inherited SIG_IGN: Ctrl-C is put back as a terminal would have it.
signal.signal(signal.SIGINT, signal.default_int_handler)

unwound = []

def interrupting(c):
    c.sleep(1.0)
    os.kill(os.getpid(), signal.SIGINT)  # lands in the main thread, which runs `run`
    if sys.argv[1] == "twice":  # a script that never sleeps again: only a second Ctrl-C leaves
        time.sleep(0.5)  # the first handled (two at once would be one), the baton kept
        os.kill(os.getpid(), signal.SIGINT)
        while True:
            pass
    try:
        c.sleep(1.0)
    finally:
        unwound.append("interrupting")

def patient(c):
    try:
        while True:
            c.sleep(0.25)
    finally:
        unwound.append("patient")

before = threading.active_count()
procs = Processes(VirtualClock())
procs.spawn("interrupting", interrupting)
procs.spawn("patient", patient)
try:
    procs.run()
except KeyboardInterrupt:
    print("KeyboardInterrupt", sorted(unwound), threading.active_count() - before, signal.getsignal(signal.SIGINT)
          is signal.default_int_handler)
"""


@pytest.mark.parametrize("presses", ["once", "twice"])
def test_ctrl_c_in_the_main_thread_stops_the_scripts_and_ends_run(presses: str) -> None:
    """Ctrl-C reaches the main thread only, the one in `run`: once, every script is stopped at its
    next sleep and unwinds, and `run` raises KeyboardInterrupt with every thread joined; twice (a
    script that never sleeps again), `run` leaves at once and the process still ends."""
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(CTRL_C), presses], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 0, done.stderr
    if presses == "once":
        assert done.stdout.split() == ["KeyboardInterrupt", "['interrupting',", "'patient']", "0", "True"]
    else:  # the spinning script's thread left behind (a daemon), nobody else unwound: it holds the baton
        assert done.stdout.split() == ["KeyboardInterrupt", "[]", "2", "True"]


@pytest.mark.skipif(not hasattr(os, "sched_getaffinity"), reason="CPU affinity: Linux")
def test_a_script_runs_with_every_cpu_the_caller_had() -> None:
    """A hand-over wakes the next script on the CPU handing over; running, it may use them all again."""
    cpus = os.sched_getaffinity(0)
    seen: list[set[int]] = []

    def script(c: Clock) -> None:
        for _ in range(5):
            seen.append(os.sched_getaffinity(0))
            c.sleep(0.1)

    procs = Processes(VirtualClock())
    for name in "ab":
        procs.spawn(name, script)
    procs.run()
    assert seen == [cpus] * 10 and os.sched_getaffinity(0) == cpus



def test_sleep_until_looks_when_and_in_the_order_its_sleeps_would_and_hands_over_only_for_an_answer() -> None:
    """Two scripts wait, looking every 0.5 s and 0.3 s, for the world's counter to pass a mark: with
    `sleep_until` the looks come at the same times in the same order as a loop of sleeps and looks."""
    def once(use_sleep_until: bool) -> tuple[list[tuple[str, float]], list[object], int, set[str]]:
        clock = VirtualClock()
        counter = [0]
        clock.scheduler.every(0.1, lambda now_us: counter.__setitem__(0, counter[0] + 1), "world")
        looks: list[tuple[str, float, str]] = []

        def waiter(name: str, period_s: float, mark: int) -> Callable[[Clock], float]:
            def body(c: Clock) -> float:
                def look() -> float | None:
                    looks.append((name, c.time(), threading.current_thread().name))
                    return c.time() if counter[0] >= mark else None

                if use_sleep_until:
                    return c.sleep_until(look, period_s)
                while True:
                    c.sleep(period_s)
                    if (answer := look()) is not None:
                        return answer

            return body

        procs = Processes(clock)
        handles = [procs.spawn("a", waiter("a", 0.5, 25)), procs.spawn("b", waiter("b", 0.3, 40))]
        procs.run()
        return ([(n, t) for n, t, _ in looks], [h.result for h in handles], procs.hand_overs,
                {thread for _, _, thread in looks})

    plain, plain_results, plain_hand_overs, _ = once(False)
    looked, results, hand_overs, threads = once(True)
    assert looked == plain and results == plain_results == [2.5, 3.9]
    assert len(looked) == 5 + 13
    # run -> a -> b (both start and wait) -> a answers (its thread wakes, ends) -> b answers -> run.
    assert hand_overs == 5 < plain_hand_overs
    assert threads == {"process-a", "process-b"}  # a look runs in whichever script's thread holds the baton


def test_what_a_look_raises_is_raised_in_its_own_scripts_thread() -> None:
    clock = VirtualClock()
    caught: list[tuple[str, str]] = []

    def look() -> None:
        if clock.time() >= 1.0:
            raise LookupError("gone")

    def waiter(c: Clock) -> None:
        try:
            c.sleep_until(look, 0.25)
        except LookupError as exc:
            caught.append((str(exc), threading.current_thread().name))

    def other(c: Clock) -> None:
        c.sleep(5.0)

    procs = Processes(clock)
    procs.spawn("waiter", waiter)
    procs.spawn("other", other)
    procs.run()
    assert caught == [("gone", "process-waiter")]


def test_a_script_waiting_on_a_look_is_stopped_when_another_fails_and_unwinds() -> None:
    clock = VirtualClock()
    unwound: list[str] = []

    def waiter(c: Clock) -> None:
        try:
            c.sleep_until(lambda: None, 0.5)  # never answers
        finally:
            unwound.append("waiter")

    def failing(c: Clock) -> None:
        c.sleep(2.0)
        raise RuntimeError("broke")

    procs = Processes(clock)
    procs.spawn("waiter", waiter)
    procs.spawn("failing", failing)
    with pytest.raises(RuntimeError, match="broke"):
        procs.run()
    assert unwound == ["waiter"] and clock.time() == 2.0


def test_sleep_until_on_a_plain_clock_is_a_loop_of_its_sleeps() -> None:
    clock = VirtualClock()
    seen: list[float] = []

    def look() -> str | None:
        seen.append(clock.time())
        return "late enough" if clock.time() >= 1.0 else None

    assert clock.sleep_until(look, 0.3) == "late enough"
    assert seen == pytest.approx([0.3, 0.6, 0.9, 1.2]) and clock.time() == pytest.approx(1.2)
