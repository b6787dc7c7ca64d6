"""Several blocking mission scripts on one clock, one at a time: the aPads' loops of a swarm.

A mission script is ordinary blocking code that waits with `clock.sleep` (the paper's Listing 1,
the energy-sharing loop). One aPad, one script: it drives the clock itself. Several aPads need
several scripts on the one clock, and the clock's `sleep` runs the whole world, so two scripts
must never sleep at once. `Processes` gives each script an OS thread (so the script stays plain
blocking code, deep waits inside the API included) and a `ProcessClock` of its own, and lets
exactly one run at any moment (a discrete-event simulation in the manner of SimPy's processes):
a script that sleeps parks until its wake time and, before it parks, moves the shared clock on to
the earliest wake time of all and hands the baton to that script. Scripts due at the same instant
resume in the order they went to sleep (spawn order first). So a lockstep swarm is as
deterministic as a single aPad, and the same code runs on the wall clock in the field.

Threads, not greenlets (issue 19): a greenlet runs on a stack switched in and out of the one
thread's C stack, and code that walks the C stack (numpy's temporary elision calls glibc's
`backtrace()` for arrays over 256 KiB, numpy issue 13042; profilers; any C library) runs off that
stack and crashes the process. A thread has a real C stack of its own, so nothing can. The
baton: each process waits on a lock of its own, and the holder hands over by releasing the next
one's lock and acquiring its own (no busy wait, no timeout, no notify_all: which thread runs next
is decided before the hand-over, by the one queue, never by the OS). There is no hand-over when
the sleeper is next again; a bay120 run of 40 minutes makes about 24,000. Each is a futex wake and
a GIL hand-over, cheap on one CPU; the next thread is woken on the CPU of the one handing over
(`_Steering`), without which a bay120 run took half as long again as on greenlets (with it, as
long: bench/processes.py, bench/scenario_speed.py).

The thread that calls `run` is the coordinator: it starts the scripts' threads, gives the baton
to the first and waits for it to come back when every script has ended. A script that ends hands
the baton on itself, so the coordinator does nothing meanwhile. Python runs signal handlers in the
main thread only: `run` called there (as `vil run` does) gets the Ctrl-C; it stops every script
at its next sleep, waits for them to unwind and raises the KeyboardInterrupt. A second Ctrl-C
meanwhile (a script that never sleeps again) leaves at once, the scripts' threads (daemons)
abandoned.

Bounded: a script that raises ends `run` with that exception, and so does the world (a task or a
handler that raises inside the clock's `sleep`); the scripts are stopped at their next sleep
with `ProcessStopped`, so they unwind their `finally` blocks. Every thread is joined before `run`
returns or raises (but after a second Ctrl-C).
"""

from __future__ import annotations

import contextvars
import heapq
import os
import signal
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Generic, TypeVar

from missiontime.clocks import Clock, Declared, Scheduler, seconds_to_us, us_to_s
from missiontime.event_clock import EventClock, Waiting

T = TypeVar("T")

HOME_LOOK_S = 0.1  # `run` looks for the baton's return this often (wall time), running signal handlers between
NEVER_US = 2**63 - 1  # queued there: a script that only news can wake (event platform)


class ProcessStopped(BaseException):
    """Raised inside a script's sleep when the coordinator stops it (another script or the world
    failed). A BaseException, as GeneratorExit is: a script's `except Exception` must not swallow
    it and sleep again (it would be stopped again at once, for ever)."""


class ProcessClock:
    """The clock one script sees: the shared clock's time; `sleep` parks the script until then."""

    def __init__(self, coordinator: Processes, process: _Process) -> None:
        self._coordinator, self._process = coordinator, process
        self.scheduler: Scheduler = coordinator.clock.scheduler

    @property
    def now_us(self) -> int:
        return self._coordinator.clock.now_us

    def time(self) -> float:
        return us_to_s(self.now_us)

    def sleep(self, dt_s: float) -> None:
        self._coordinator.park(self._process, self.now_us + seconds_to_us(max(dt_s, 0.0)))

    def sleep_until(self, look: Callable[[], T | None], period_s: float, declared: Declared | None = None) -> T:
        """Looked at by whichever thread holds the baton when the script's time comes: a look that
        does not answer sleeps the script again without waking its thread (no hand-over). On an
        `EventClock` its time comes after news it reads and at its wake time, as the clock's own waits look."""
        return self._coordinator.park_until(self._process, look, seconds_to_us(max(period_s, 0.0)), declared)


def _held_lock() -> threading.Lock:
    lock = threading.Lock()
    lock.acquire()
    return lock


class _Steering:
    """Wakes the next script on the CPU of the one handing over (Linux).

    Left alone, the kernel wakes a thread on an idle CPU, as the waker is still running: every
    hand-over then wakes another CPU (in a virtual machine, an exit to the host) and moves the
    world's working set between caches, about a hundred microseconds a time: a bay120 run took
    half as long again. So the thread handing over first allows the next one only its own CPU, and
    the next one, running, allows itself every CPU again (the kernel may move it then, as any
    thread): a few microseconds. Placement only: the order is the queue's.
    """

    def __init__(self) -> None:
        import ctypes  # here, not at import: only swarms pay for it

        self.cpus = os.sched_getaffinity(0)
        getcpu = ctypes.PyDLL(None).sched_getcpu  # the GIL kept: a read of the vDSO
        getcpu.restype, getcpu.argtypes = ctypes.c_int, []
        self._getcpu: Callable[[], int] = getcpu
        self.on = len(self.cpus) > 1

    @classmethod
    def make(cls) -> _Steering | None:
        if not hasattr(os, "sched_setaffinity"):
            return None
        try:
            return cls()
        except (OSError, AttributeError):  # no sched_getcpu in this C library
            return None

    def towards_me(self, thread: threading.Thread) -> None:
        if self.on and thread.native_id is not None:
            try:
                os.sched_setaffinity(thread.native_id, {self._getcpu()})
            except (OSError, ValueError, OverflowError):  # a CPU gone, a cpuset changed: the kernel's placement
                self.on = False

    def free(self) -> None:
        """The thread now running may run anywhere again."""
        if self.on:
            try:
                os.sched_setaffinity(0, self.cpus)
            except OSError:
                self.on = False


@dataclass(eq=False)
class _Process:
    name: str
    body: Callable[[], None]  # the script with its result and failure handling
    turn: threading.Lock = field(default_factory=_held_lock)  # released: this process holds the baton
    thread: threading.Thread | None = None  # started by `run`
    stop: bool = False
    # While it sleeps until an answer (`ProcessClock.sleep_until`): its look, the period between looks,
    # and what the look answered or raised, for the script to take when it wakes.
    look: Callable[[], object] | None = None
    period_us: int = 0
    waiting: Waiting | None = None  # event platform: the look's wait (its grid, wake time, news)
    entry: int = -1  # the sequence number of its queue entry; older entries are stale
    answer: object = None
    raised: BaseException | None = None


@dataclass
class Handle(Generic[T]):
    """A spawned script; `result` once `Processes.run` has returned."""

    name: str
    result: T | None = None


class Processes:
    """Run scripts `spawn`ed on `clock` until all have returned (`run`).

    The baton: the script that sleeps moves the clock on itself and hands over straight to the next
    script (to none when the sleeper is next again); a script that ends does the same, and the last
    one hands it back to `run`. The order is a coordinator's: one queue, popped at the same moments.
    `current` names the script holding the baton (None before and after `run`); `hand_overs` counts
    the hand-overs between threads.
    """

    def __init__(self, clock: Clock) -> None:
        self.clock = clock
        self._queue: list[tuple[int, int, _Process]] = []  # (wake_us, sequence, process)
        self._sequence = 0
        self._error: BaseException | None = None  # the first failure: a script's, the world's, a Ctrl-C
        self._processes: list[_Process] = []
        self._home = _held_lock()  # released: the baton is back with the thread in `run`
        self._steering: _Steering | None = None  # made by `run` (Linux)
        self.current: str | None = None
        self.hand_overs = 0
        self._seen_news: int | None = None  # EventClock: the news the looking scripts were last woken for

    def spawn(self, name: str, script: Callable[[Clock], T]) -> Handle[T]:
        """Add a script; it starts at `run`, at the clock's time then, with its own `ProcessClock`."""
        handle: Handle[T] = Handle(name)

        def body() -> None:
            try:
                if not process.stop:
                    handle.result = script(own_clock)
            except ProcessStopped:
                pass
            except BaseException as exc:  # handed to `run`, which raises it in the caller
                self._fail(exc)

        process = _Process(name, body)
        own_clock = ProcessClock(self, process)
        self._processes.append(process)
        return handle

    def park(self, process: _Process, wake_us: int) -> None:
        """Called from the running script: sleep until `wake_us`, the others running meanwhile."""
        if process.stop:
            raise ProcessStopped(process.name)
        self._push(process, wake_us)
        following = self._next()
        if following is not process:
            self._hand_to(following)
            process.turn.acquire()  # back here when our turn comes
            self._running()
        if process.stop:
            raise ProcessStopped(process.name)

    def park_until(self, process: _Process, look: Callable[[], T | None], period_us: int,
                   declared: Declared | None = None) -> T:
        """Called from the running script: sleep `period_us` at a time until `look()` answers; the look
        runs in the thread holding the baton at each wake time, in the order the script's own sleeps
        would have woken it, and only an answer (or an exception, re-raised here) wakes its thread.
        On an `EventClock` the wake times are the news it reads and its wake time (`_next_look_us`)."""
        process.look, process.period_us = look, max(period_us, 1)
        if isinstance(self.clock, EventClock):
            process.waiting = Waiting(self.clock, us_to_s(process.period_us), declared)
        try:
            self.park(process, self._next_look_us(process))
        finally:
            process.look = process.waiting = None
        answer, raised = process.answer, process.raised
        process.answer = process.raised = None
        if raised is not None:
            raise raised
        return answer  # type: ignore[return-value]  # a look's answer, never None here

    def _push(self, process: _Process, wake_us: int) -> None:
        process.entry = self._sequence
        heapq.heappush(self._queue, (wake_us, self._sequence, process))
        self._sequence += 1

    def _next_look_us(self, process: _Process) -> int:
        """When a sleeping script looks next by time alone: a period on (lockstep), or its wake time on
        its grid (`EventClock`; never, when only news can answer it)."""
        if process.waiting is None:
            return self.clock.now_us + process.period_us
        wake = process.waiting.wake_us()
        return NEVER_US if wake is None else wake

    def _until_news(self, clock: EventClock, wake_us: int) -> bool:
        """Run the world towards `wake_us`, stopping at news (the world's, or a script's since the last
        look): then every looking script looks at its next grid instant, if that comes first. True: news."""
        if clock.news() == self._seen_news and not clock.advance_until_news(None if wake_us == NEVER_US else wake_us):
            return False
        self._seen_news = clock.news()
        now = clock.now_us
        for wake, seq, process in list(self._queue):
            waiting = process.waiting
            if seq == process.entry and waiting is not None and waiting.news_for_it():
                at = waiting.look_at(now)
                if at < wake:
                    self._push(process, at)
        return True

    def _fail(self, exc: BaseException) -> None:
        if self._error is None:
            self._error = exc  # from now on every script is stopped at its next turn

    def _next(self) -> _Process | None:
        """Run the world to the earliest wake time and return that script, marked stopped if
        anything failed; None when no script is left (the baton goes back to `run`). A sleeper has
        just queued itself, so it gets a script."""
        clock = self.clock
        while self._queue:
            wake_us, seq, process = self._queue[0]
            if seq == process.entry and process.thread is not None and self._error is None \
                    and isinstance(clock, EventClock):
                try:
                    if self._until_news(clock, wake_us):
                        continue
                except BaseException as exc:  # the world failed: stop every script, then raise it in `run`
                    self._fail(exc)
            heapq.heappop(self._queue)
            if seq != process.entry or process.thread is None:  # stale, or never started (`run` failed)
                continue
            if self._error is None:
                try:  # a zero sleep too delivers what is due now, as the clock's own sleep(0) does
                    self.clock.sleep(us_to_s(max(wake_us - self.clock.now_us, 0)))
                except BaseException as exc:  # the world failed: stop every script, then raise it in `run`
                    self._fail(exc)
            if process.look is not None and self._error is None and not self._looked(process):
                self._push(process, self._next_look_us(process))  # as its own sleep would have
                continue
            process.stop = self._error is not None
            return process
        return None

    @staticmethod
    def _looked(process: _Process) -> bool:
        """Run a sleeping script's look; True if it answered or raised (the script wakes to take it)."""
        assert process.look is not None
        if process.waiting is not None:
            process.waiting.looks()
        try:
            process.answer = process.look()
        except BaseException as exc:  # the script's own to raise, in its own thread
            process.raised = exc
            return True
        return process.answer is not None

    def _hand_to(self, following: _Process | None) -> None:
        """Give the baton to `following` (to `run` for None); the caller then waits for its own."""
        self.hand_overs += 1
        if following is None:
            self.current = None
            self._home.release()
        else:
            self.current = following.name
            if self._steering is not None and following.thread is not None:
                self._steering.towards_me(following.thread)
            following.turn.release()

    def _running(self) -> None:
        """First thing a script's thread does when the baton comes to it."""
        if self._steering is not None:
            self._steering.free()

    def _thread_main(self, process: _Process) -> None:
        process.turn.acquire()  # the first turn
        self._running()
        process.body()  # keeps its failure for `run`: nothing gets past it
        self._hand_to(self._next())  # the next script, or `run` when this was the last

    def run(self) -> None:
        """Resume the earliest-waking script, one at a time, until every script has returned."""
        for process in self._processes:
            self._push(process, self.clock.now_us)
        self._steering = _Steering.make()
        restore = self._catch_ctrl_c()
        try:
            try:
                for process in self._processes:
                    self._start(process)
            except BaseException as exc:  # no thread for a script: the started ones are run to their stop
                self._fail(exc)
            self._hand_to(self._next())
            # The last script to end hands the baton back. Waited for in slices: the OS may deliver a
            # Ctrl-C to a script's thread, and Python runs its handler in the main thread only when
            # that thread runs again (a lock wait without a timeout may never return to it).
            while not self._home.acquire(timeout=HOME_LOOK_S):
                pass
        finally:  # left without the baton only by a second Ctrl-C: the threads are abandoned, not joined
            restore()
            self.current = None
        for process in self._processes:
            if process.thread is not None:
                process.thread.join()  # it has handed the baton on: only its thread's exit is left
        if self._error is not None:
            raise self._error

    def _start(self, process: _Process) -> None:
        context = contextvars.copy_context()  # the caller's (numpy's errstate, decimal's context ...)
        thread = threading.Thread(target=context.run, args=(self._thread_main, process),
                                  name=f"process-{process.name}", daemon=True)
        process.thread = thread
        try:
            thread.start()  # it waits for its turn
        except BaseException:
            if thread.ident is None:  # not started (a Ctrl-C in `start` comes once the thread exists)
                process.thread = None
            raise

    def _catch_ctrl_c(self) -> Callable[[], None]:
        """In the main thread, Python's Ctrl-C handler raises KeyboardInterrupt wherever that thread
        is, which could be in the middle of a hand-over. While `run` runs, the first Ctrl-C instead
        stops every script at its next sleep and `run` raises the KeyboardInterrupt once they have
        unwound; a second one raises at once. Returns the undo."""
        if (threading.current_thread() is not threading.main_thread()
                or signal.getsignal(signal.SIGINT) is not signal.default_int_handler):
            return lambda: None
        pressed: list[KeyboardInterrupt] = []

        def on_ctrl_c(signum: int, frame: object) -> None:
            if pressed:
                raise KeyboardInterrupt
            pressed.append(KeyboardInterrupt())
            self._fail(pressed[0])

        previous = signal.signal(signal.SIGINT, on_ctrl_c)

        def restore() -> None:
            signal.signal(signal.SIGINT, previous)

        return restore
