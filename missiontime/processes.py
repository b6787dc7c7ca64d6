"""Several blocking mission scripts on one clock, one at a time: the aPads' loops of a swarm.

A mission script is ordinary blocking code that waits with `clock.sleep` (the paper's Listing 1,
the energy-sharing loop). One aPad, one script: it drives the clock itself. Several aPads need
several scripts on the one clock, and the clock's `sleep` runs the whole world, so two scripts
must never sleep at once. `Processes` gives each script a thread and a `ProcessClock` of its own
and lets exactly one thread run at any moment (a discrete-event simulation in the manner of
SimPy's processes): a script that sleeps parks until its wake time, the coordinator moves the
shared clock on to the earliest wake time of all and resumes that script. Scripts due at the
same instant resume in the order they went to sleep (spawn order first). So a lockstep swarm
is as deterministic as a single aPad, and the same code runs on the wall clock in the field.

Bounded: a script that raises ends `run` with that exception (the others are stopped at their
next sleep with `ProcessStopped`, so they unwind their `finally` blocks).
"""

from __future__ import annotations

import heapq
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Generic, TypeVar

from missiontime.clocks import Clock, Scheduler, seconds_to_us, us_to_s

T = TypeVar("T")


class ProcessStopped(Exception):
    """Raised inside a script's sleep when the coordinator stops it (another script failed)."""


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


def _closed_gate() -> threading.Lock:
    gate = threading.Lock()
    gate.acquire()
    return gate


@dataclass(eq=False)
class _Process:
    name: str
    order: int
    # A held lock as a one-shot gate: `release` lets the one waiter through. A hand-over is one
    # futex wake, about half the cost of an Event's set/wait/clear (a swarm makes two per sleep).
    go: threading.Lock = field(default_factory=_closed_gate)
    done: bool = False
    stop: bool = False
    error: BaseException | None = None


@dataclass
class Handle(Generic[T]):
    """A spawned script; `result` once `Processes.run` has returned."""

    name: str
    result: T | None = None


class Processes:
    """Run scripts `spawn`ed on `clock` until all have returned (`run`, from the clock's thread)."""

    def __init__(self, clock: Clock) -> None:
        self.clock = clock
        self._queue: list[tuple[int, int, _Process]] = []  # (wake_us, sequence, process)
        self._sequence = 0
        self._yielded = _closed_gate()  # released when the running script has parked or finished
        self._threads: list[threading.Thread] = []
        self._processes: list[_Process] = []

    def spawn(self, name: str, script: Callable[[Clock], T]) -> Handle[T]:
        """Add a script; it starts at `run`, at the clock's time then, with its own `ProcessClock`."""
        process = _Process(name, len(self._processes))
        handle: Handle[T] = Handle(name)
        own_clock = ProcessClock(self, process)

        def body() -> None:
            process.go.acquire()
            try:
                if not process.stop:
                    handle.result = script(own_clock)
            except ProcessStopped:
                pass
            except BaseException as exc:  # handed to `run`, which raises it in the clock's thread
                process.error = exc
            finally:
                process.done = True
                self._yielded.release()

        self._processes.append(process)
        self._threads.append(threading.Thread(target=body, name=f"process-{name}", daemon=True))
        return handle

    def park(self, process: _Process, wake_us: int) -> None:
        """Called from the running script's thread: hand over to the coordinator until `wake_us`."""
        if process.stop:
            raise ProcessStopped(process.name)
        self._push(process, wake_us)
        self._yielded.release()
        process.go.acquire()
        if process.stop:
            raise ProcessStopped(process.name)

    def _push(self, process: _Process, wake_us: int) -> None:
        heapq.heappush(self._queue, (wake_us, self._sequence, process))
        self._sequence += 1

    def run(self) -> None:
        """Resume the earliest-waking script, one at a time, until every script has returned."""
        for thread in self._threads:
            thread.start()
        for process in self._processes:
            self._push(process, self.clock.now_us)
        error: BaseException | None = None
        while self._queue:
            wake_us, _, process = heapq.heappop(self._queue)
            if error is None and wake_us > self.clock.now_us:
                self.clock.sleep(us_to_s(wake_us - self.clock.now_us))
            process.stop = error is not None
            process.go.release()
            self._yielded.acquire()
            if process.error is not None and error is None:
                error = process.error
        for thread in self._threads:
            thread.join()
        if error is not None:
            raise error
