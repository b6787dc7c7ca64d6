"""Several blocking mission scripts on one clock, one at a time: the aPads' loops of a swarm.

A mission script is ordinary blocking code that waits with `clock.sleep` (the paper's Listing 1,
the energy-sharing loop). One aPad, one script: it drives the clock itself. Several aPads need
several scripts on the one clock, and the clock's `sleep` runs the whole world, so two scripts
must never sleep at once. `Processes` gives each script a greenlet (a coroutine with its own stack,
so the script stays plain blocking code) and a `ProcessClock` of its own, and lets exactly one run
at any moment (a discrete-event simulation in the manner of SimPy's processes): a script that
sleeps parks until its wake time and, before it parks, moves the shared clock on to the earliest
wake time of all and switches to that script. Scripts due at the same instant resume in the
order they went to sleep (spawn order first). So a lockstep swarm is as deterministic as a single
aPad, and the same code runs on the wall clock in the field.

Greenlets, not threads: the scripts never run at once anyway, and a switch between greenlets is
about a microsecond in the one thread that called `run`, where a hand-over between OS threads
(a futex wake, then the GIL) cost a fifth of a bay120 run.

Bounded: a script that raises ends `run` with that exception, and so does the world (a task or a
handler that raises inside the clock's `sleep`); the scripts are stopped at their next sleep
with `ProcessStopped`, so they unwind their `finally` blocks.
"""

from __future__ import annotations

import heapq
from collections.abc import Callable
from dataclasses import dataclass
from typing import Generic, TypeVar

from greenlet import greenlet

from missiontime.clocks import Clock, Scheduler, seconds_to_us, us_to_s

T = TypeVar("T")


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


@dataclass(eq=False)
class _Process:
    name: str
    order: int
    body: greenlet | None = None  # made at `run`, child of the greenlet that runs `run`
    done: bool = False
    stop: bool = False


@dataclass
class Handle(Generic[T]):
    """A spawned script; `result` once `Processes.run` has returned."""

    name: str
    result: T | None = None


class Processes:
    """Run scripts `spawn`ed on `clock` until all have returned (`run`).

    The baton: the script that sleeps moves the clock on itself and switches straight to the next
    script (none when the sleeper is next again). A script that ends returns to `run`, which does
    the same for it. The order is a coordinator's: one queue, popped at the same moments.
    `current` names the script running now (None between them).
    """

    def __init__(self, clock: Clock) -> None:
        self.clock = clock
        self._queue: list[tuple[int, int, _Process]] = []  # (wake_us, sequence, process)
        self._sequence = 0
        self._error: BaseException | None = None  # the first failure: a script's, or the world's
        self._processes: list[_Process] = []
        self._scripts: list[Callable[[], None]] = []
        self.current: str | None = None

    def spawn(self, name: str, script: Callable[[Clock], T]) -> Handle[T]:
        """Add a script; it starts at `run`, at the clock's time then, with its own `ProcessClock`."""
        process = _Process(name, len(self._processes))
        handle: Handle[T] = Handle(name)
        own_clock = ProcessClock(self, process)

        def body() -> None:
            try:
                if not process.stop:
                    handle.result = script(own_clock)
            except ProcessStopped:
                pass
            except BaseException as exc:  # handed to `run`, which raises it in the caller
                self._fail(exc)
            process.done = True

        self._processes.append(process)
        self._scripts.append(body)
        return handle

    def park(self, process: _Process, wake_us: int) -> None:
        """Called from the running script: sleep until `wake_us`, the others running meanwhile."""
        if process.stop:
            raise ProcessStopped(process.name)
        self._push(process, wake_us)
        following = self._next()
        if following is not process:
            following.body.switch()  # type: ignore[union-attr]  # back here when our turn comes
        self.current = process.name
        if process.stop:
            raise ProcessStopped(process.name)

    def _push(self, process: _Process, wake_us: int) -> None:
        heapq.heappush(self._queue, (wake_us, self._sequence, process))
        self._sequence += 1

    def _fail(self, exc: BaseException) -> None:
        if self._error is None:
            self._error = exc  # from now on every script is stopped at its next turn

    def _next(self) -> _Process:
        """Run the world to the earliest wake time and return that script, marked stopped if
        anything failed. The queue is never empty here: the caller has just queued itself, or
        `run` checked."""
        wake_us, _, process = heapq.heappop(self._queue)
        if self._error is None:
            try:  # a zero sleep too delivers what is due now, as the clock's own sleep(0) does
                self.clock.sleep(us_to_s(max(wake_us - self.clock.now_us, 0)))
            except BaseException as exc:  # the world failed: stop every script, then raise it in `run`
                self._fail(exc)
        process.stop = self._error is not None
        return process

    def run(self) -> None:
        """Resume the earliest-waking script, one at a time, until every script has returned."""
        for process, body in zip(self._processes, self._scripts, strict=True):
            process.body = greenlet(body)
            self._push(process, self.clock.now_us)
        try:
            while self._queue:
                following = self._next()
                self.current = following.name
                following.body.switch()  # type: ignore[union-attr]  # returns when a script has ended
        finally:
            self.current = None
        if self._error is not None:
            raise self._error
