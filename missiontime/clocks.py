"""Mission time and the one scheduler that drives the world.

Time is an integer count of microseconds. `sleep` belongs to the clock: the wall clock really
waits (on the transports' sockets, so messages are handled as they arrive), the virtual clock
runs every periodic task and every message delivery up to `t + dt` as fast as the CPU allows
and returns. A mission script written as `while busy(): clock.sleep(1)` runs unchanged on both.

Models never see this module: they take `dt` as an argument. Runners register their periodic
`Task`s and their receive `Poller`s with a `Scheduler`.
"""

from __future__ import annotations

import heapq
import select
import time
from collections.abc import Callable, Hashable
from dataclasses import dataclass, field
from typing import Protocol, TypeVar

T = TypeVar("T")

US_PER_S = 1_000_000
# A lockstep instant that keeps producing messages forever is a bug (two parties echoing).
MAX_DRAIN_ROUNDS = 10_000


def seconds_to_us(t_s: float) -> int:
    return round(t_s * US_PER_S)


def us_to_s(t_us: int) -> float:
    return t_us / US_PER_S


def unix_time_us() -> int:
    """Wall-clock Unix time now: the epoch of a live run's logs (mission time 0 is then)."""
    return int(time.time() * US_PER_S)


def mm_ss(t_s: float) -> str:
    """Mission time as the console and the logs show it: minutes:seconds, whole seconds."""
    t = max(int(t_s), 0)
    return f"{t // 60:02d}:{t % 60:02d}"


@dataclass(eq=False)
class Task:
    """A callback run every `period_us` of mission time, first at `next_us`.

    Change `period_us`, `next_us` or `active` through `Scheduler.reschedule`, which keeps the
    queue in order; setting `active = False` directly also works (the task is dropped when due).
    """

    name: str
    period_us: int
    callback: Callable[[int], None]  # receives the mission time now_us
    next_us: int
    order: int  # registration order: ties run in the order tasks were added
    active: bool = True
    generation: int = 0  # bumped on every reschedule; older queue entries are stale


@dataclass(frozen=True)
class Declared:
    """What a wait declares it waits for: a clock that jumps from event to event looks only then
    (`missiontime.event_clock`); the others look at every period whatever it says.

    `wake_at`: the first mission second time alone could answer it (None: only news can). `news`: what it
    reads that only a message changes, as one comparable value (None: anything the world hears)."""

    wake_at: Callable[[], float | None] | None = None
    news: Callable[[], Hashable] | None = None


class Poller(Protocol):
    def poll(self) -> bool:
        """Handle whatever has arrived; True if anything was handled."""
        ...

    def fileno(self) -> int | None: ...


class Doorbell:
    """Counts deliveries into in-memory inboxes (`mavlink_dialect.transport.MemoryTransport` rings it).

    A poller that offers `ring_on(bell) -> bool` and answers True receives nothing but what rings the
    bell. When every poller of a scheduler does, its drain polls only if the bell rang since all
    inboxes were last seen empty: most lockstep instants (a physics step) deliver nothing, and
    polling every receiver for nothing was a tenth of a run.
    """

    __slots__ = ("rings",)

    def __init__(self) -> None:
        self.rings = 0


@dataclass
class Scheduler:
    """Periodic tasks plus receive pollers; the clocks decide how time passes between them.

    Due tasks sit in a heap of (next_us, order): lockstep runs fire hundreds of thousands of
    tasks, so finding the next one must not scan them all.
    """

    tasks: list[Task] = field(default_factory=list)
    pollers: list[Poller] = field(default_factory=list)
    _queue: list[tuple[int, int, int, Task]] = field(default_factory=list, repr=False)
    # Lockstep (True): an instant whose messages never stop arriving is a bug, raised. In the field
    # (the wall clock sets False) it is a flood from outside: `drain` stops at the bound, counts it
    # in `drains_cut`, and time goes on (the tasks run, the next drain takes up the rest).
    strict_drain: bool = True
    drains_cut: int = 0
    bell: Doorbell = field(default_factory=Doorbell, repr=False)
    _rung: dict[int, bool] = field(default_factory=dict, repr=False)  # id(poller) -> rings the bell
    _all_rung: bool = field(default=True, repr=False)
    _quiet_at: int = -1  # the bell's count when every inbox was last seen empty; -1: not known
    # Where the run is (the clocks and `run_due` set it): the instant, and the order of the task whose
    # callback runs (None while messages are delivered). A part that skips ticks of its own while
    # nothing needs them (a resting aPad's physics, `apad_sitl.parking`) tells from it which of them
    # would have run by now.
    now_us: int = 0
    running: int | None = None

    def every(self, period_s: float, callback: Callable[[int], None], name: str, start_us: int = 0) -> Task:
        period_us = seconds_to_us(period_s)
        if period_us <= 0:
            raise ValueError(f"task {name!r}: period must be positive, got {period_s} s")
        task = Task(name, period_us, callback, start_us, len(self.tasks))
        self.tasks.append(task)
        heapq.heappush(self._queue, (task.next_us, task.order, task.generation, task))
        return task

    def reschedule(
        self, task: Task, *, period_us: int | None = None, next_us: int | None = None, active: bool | None = None
    ) -> None:
        if period_us is not None:
            if period_us <= 0:
                raise ValueError(f"task {task.name!r}: period must be positive")
            task.period_us = period_us
        if next_us is not None:
            task.next_us = next_us
        if active is not None:
            task.active = active
        task.generation += 1
        if task.active:
            heapq.heappush(self._queue, (task.next_us, task.order, task.generation, task))

    def add_poller(self, poller: Poller) -> None:
        ring_on = getattr(poller, "ring_on", None)
        self._rung[id(poller)] = bool(ring_on(self.bell)) if ring_on is not None else False
        self.pollers.append(poller)
        self._all_rung = all(self._rung.values())
        self._quiet_at = -1

    def remove_poller(self, poller: Poller) -> None:
        if poller in self.pollers:
            self.pollers.remove(poller)
            if poller not in self.pollers:
                self._rung.pop(id(poller), None)
                self._all_rung = all(self._rung.values())

    def _head(self) -> Task | None:
        """The next task to run, dropping stale and inactive queue entries."""
        queue = self._queue
        while queue:
            _, _, generation, task = queue[0]
            if task.active and generation == task.generation:
                return task
            heapq.heappop(queue)
        return None

    def next_due_us(self) -> int | None:
        task = self._head()
        return None if task is None else task.next_us

    def run_due(self, now_us: int) -> None:
        """Run every task due at or before `now_us`, earliest first; deliver messages after each."""
        queue = self._queue
        self.now_us, self.running = now_us, None
        while True:
            task = self._head()
            if task is None or task.next_us > now_us:
                return
            instant = task.next_us
            # Every task of one instant runs before the messages they sent are delivered.
            while task is not None and task.next_us == instant:
                task.next_us += task.period_us  # the head's entry replaced by its next: one sift, not two
                heapq.heapreplace(queue, (task.next_us, task.order, task.generation, task))
                # Left set if the callback raises: the tasks after it in this instant did not run, and
                # what unwinds (a vehicle's close) settles as of that point.
                self.running = task.order
                task.callback(now_us)
                task = self._head()
            self.running = None
            self.drain()

    def drain(self) -> None:
        """Poll every receiver until nothing more arrives (in-memory delivery is immediate)."""
        pollers = self.pollers
        if self._all_rung:
            bell = self.bell
            for _ in range(MAX_DRAIN_ROUNDS):
                mark = bell.rings
                if mark == self._quiet_at:
                    return  # nothing delivered since every inbox was empty
                for poller in pollers:
                    poller.poll()
                if bell.rings == mark:  # each inbox emptied and none filled meanwhile
                    self._quiet_at = mark
                    return
        else:
            for _ in range(MAX_DRAIN_ROUNDS):
                progressed = False
                for poller in pollers:
                    progressed |= poller.poll()
                if not progressed:
                    return
        if self.strict_drain:
            raise RuntimeError("lockstep livelock: messages kept arriving within one instant")
        self.drains_cut += 1


class Clock(Protocol):
    scheduler: Scheduler

    @property
    def now_us(self) -> int: ...

    def time(self) -> float:
        """Mission time in seconds."""
        ...

    def sleep(self, dt_s: float) -> None: ...

    def sleep_until(self, look: Callable[[], T | None], period_s: float, declared: Declared | None = None) -> T:
        """Sleep `period_s` at a time until `look()`, called after each sleep, answers (not None);
        return the answer. What `look` raises is raised here. `declared`: what it waits for (`Declared`);
        a clock that jumps from event to event looks only then, the others at every period."""
        ...


def sleep_until(clock: Clock, look: Callable[[], T | None], period_s: float) -> T:
    """`Clock.sleep_until` as a loop of the clock's own sleeps (a clock that runs one script)."""
    while True:
        clock.sleep(period_s)
        answer = look()
        if answer is not None:
            return answer


class VirtualClock:
    """Lockstep time: `sleep(dt)` runs the world to `t + dt` at CPU speed. Deterministic."""

    def __init__(self, scheduler: Scheduler | None = None, start_us: int = 0) -> None:
        self.scheduler = scheduler or Scheduler()
        self._now_us = start_us

    @property
    def now_us(self) -> int:
        return self._now_us

    def time(self) -> float:
        return self._now_us / US_PER_S

    def sleep(self, dt_s: float) -> None:
        self.advance_to(self._now_us + seconds_to_us(max(dt_s, 0.0)))

    def sleep_until(self, look: Callable[[], T | None], period_s: float, declared: Declared | None = None) -> T:
        return sleep_until(self, look, period_s)

    def advance_to(self, target_us: int) -> None:
        sched = self.scheduler
        sched.now_us = self._now_us
        sched.drain()
        while self.run_next(target_us):
            pass
        self.moving_to(target_us)
        self._now_us = sched.now_us = max(self._now_us, target_us)
        sched.drain()

    def moving_to(self, t_us: int) -> None:
        """Time is about to move on to `t_us` (nothing at it has run yet); an `EventClock` integrates there."""

    def run_next(self, target_us: int | None) -> bool:
        """Run the next instant with a task due, if it is not after `target_us` (None: whenever it is);
        False if there is none."""
        sched = self.scheduler
        due = sched.next_due_us()
        if due is None or (target_us is not None and due > target_us):
            return False
        # Tasks already overdue (added with an old start) run now; time never goes back.
        self.moving_to(due)
        self._now_us = max(self._now_us, due)
        sched.run_due(self._now_us)
        return True


class WallClock:
    """Field time: `sleep(dt)` waits on the transports and runs tasks as they fall due."""

    # Pollers without a file descriptor (in-memory pairs) are checked at least this often.
    POLL_INTERVAL_S = 0.005
    # A task more than this late (the laptop was suspended) is re-phased, not run in a burst.
    MAX_LAG_US = US_PER_S

    def __init__(
        self,
        scheduler: Scheduler | None = None,
        start_us: int = 0,
        monotonic: Callable[[], float] = time.monotonic,
        wait: Callable[[float], None] = time.sleep,
    ) -> None:
        """`monotonic` is the wall clock; `wait` idles when no poller has a file to wait on (tests
        pass their own pair)."""
        self.scheduler = scheduler or Scheduler()
        self.scheduler.strict_drain = False
        self._monotonic, self._wait = monotonic, wait
        self._origin_s = monotonic() - start_us / US_PER_S

    @property
    def now_us(self) -> int:
        return int((self._monotonic() - self._origin_s) * US_PER_S)

    def time(self) -> float:
        return self._monotonic() - self._origin_s

    def sleep(self, dt_s: float) -> None:
        sched = self.scheduler
        deadline_us = self.now_us + seconds_to_us(max(dt_s, 0.0))
        while True:
            sched.now_us = self.now_us
            sched.drain()
            now = self.now_us
            for task in sched.tasks:
                if task.active and now - task.next_us > self.MAX_LAG_US:
                    sched.reschedule(task, next_us=now)
            sched.run_due(now)
            now = self.now_us
            if now >= deadline_us:
                return
            due = sched.next_due_us()
            wake_us = deadline_us if due is None else min(due, deadline_us)
            timeout_s = max(wake_us - now, 0) / US_PER_S
            fds = [fd for fd in (p.fileno() for p in sched.pollers) if fd is not None]
            if len(fds) < len(sched.pollers):
                timeout_s = min(timeout_s, self.POLL_INTERVAL_S)
            if fds:
                select.select(fds, [], [], timeout_s)
            else:
                self._wait(timeout_s)

    def sleep_until(self, look: Callable[[], T | None], period_s: float, declared: Declared | None = None) -> T:
        return sleep_until(self, look, period_s)


class PacedClock(VirtualClock):
    """Lockstep time that runs at most `speed` times the wall clock: a deterministic world a
    person (or a Pilot test) can watch. `speed` 1 looks like the field; the bits do not depend on it."""

    def __init__(
        self, speed: float, monotonic: Callable[[], float] = time.monotonic,
        wait: Callable[[float], None] = time.sleep, start_us: int = 0,
    ) -> None:
        """`monotonic` and `wait` are the wall clock it keeps pace with (tests pass their own);
        `start_us` > 0 starts the clock later (a resumed mission), paced from then on."""
        super().__init__(start_us=start_us)
        if speed <= 0:
            raise ValueError(f"speed must be positive, got {speed}")
        self.speed = speed
        self._monotonic, self._wait = monotonic, wait
        self._wall0, self._start_us = monotonic(), start_us

    def sleep(self, dt_s: float) -> None:
        target_us = self.now_us + seconds_to_us(max(dt_s, 0.0))
        while True:
            self.advance_to(min(target_us, self.now_us + 100_000))
            ahead_s = us_to_s(self.now_us - self._start_us) / self.speed - (self._monotonic() - self._wall0)
            if ahead_s > 0:
                self._wait(ahead_s)
            if self.now_us >= target_us:
                return
