"""Activity log of a run: uptime per eq. (3), active count per step, battery traces.

Per-agent counters and per-step scalars cost O(n) and O(steps) memory, so they are always kept
(12 bytes a step: 7 MB for a week at 1 Hz). Traces (each traced aMussel's battery, float32, and
state, uint8, at a step) cost O(n * steps): 100,000 aMussels for a 40 min run at 1 Hz would be
1.2 GB, and 12 for a week 36 MB. So traces have a budget of rows (`max_trace_rows`, default 8,192:
a 2-h mission at 1 Hz whole) and of bytes (`max_trace_bytes`, default 64 MiB): when the next row
would exceed either, every other stored row is dropped and the sampling stride doubles. The kept
rows are always the steps that are multiples of the current stride, so a trace stays evenly sampled
and holds at most `max_trace_rows` rows whatever the mission's length. What is summed over a
simulated day (`DayLedger`, given `day_us`) is counted at every step, so the per-day figures are
exact whatever the traces kept. `trace_every_steps=0` turns traces off; `trace_ids` restricts them
to some aMussels.

On the event platform a step may cover several of the model's periods (`record(..., periods=k)`, nothing
discontinuous in it: `mussel_sim.next_change`): it counts as k steps (uptime, the day's figures), the
trace keeps its rows on the periods' grid (the battery linear inside the step), and the step rows
(`step_time_us`, `active_count`) are one per step recorded plus one at each trace row inside a longer
one, so `battery_trace()`'s rows index them as in lockstep, where a step row is a step.

What counts as active (eq. (3) and the active count): ACTIVE, and SINKING unless
`sinking_counts_active=False`. The paper's simulated aMussel "transitions to a discharging battery
behaviour and becomes active" as it is released, so the 20 s it takes to reach the seabed count as
uptime there; the other reading (measuring only once on the seabed) is the option. Every step also
goes into `times` (`StateTimes`): the time in each state, whatever counts as active.

A sleeping aMussel (on a wake schedule, `mussel_sim.behaviour`) stays ACTIVE on the seabed between
its wakes: it is doing its job, monitoring on its schedule, so the whole sleeping interval on the
seabed counts as uptime; docked, floating and depleted do not, as for any aMussel. What its schedule
achieved is counted apart as samples (`samples()`): one scheduled at each wake, taken if it was
ACTIVE then (the fleet model counts them, `FleetState.samples_taken` / `samples_due`; an always-on
aMussel, which monitors all the time, has none).

For crash-safe checkpoints of long missions the recorder splits in two: `head()` is its fixed-size
state (counters, stride), `rows_since(k)` the rows that grow with the mission (per-step active count
and time, battery trace rows) added from step k on, so a checkpoint can append them to a file and
never rewrite them. `Recorder.restore(head, rows)` rebuilds the recorder from a head and every row
since step 0. Trace rows that a later decimation dropped may be among those rows: the restore drops
them again (they are the rows whose step is not a multiple of the head's stride), so an append-only
file stays correct across decimations, and it holds at most the budget's rows plus half of them per
decimation.
"""

from __future__ import annotations

from bisect import bisect_left
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mussel_sim.day_ledger import DayLedger
from mussel_sim.fleet_state import ACTIVE, DEPLETED, N_STATES, SINKING, FleetState
from mussel_sim.memo import LastMade
from mussel_sim.state_time import StateTimes

DEFAULT_MAX_TRACE_BYTES = 64 * 2**20
DEFAULT_MAX_TRACE_ROWS = 8192


@dataclass(frozen=True)
class UptimeSummary:
    """The paper's Table II columns for the aMussels (uptime in %, eq. (3))."""

    n_steps: int
    avg_uptime_pct: float
    max_uptime_pct: float
    min_uptime_pct: float
    avg_active: float  # mean number of active aMussels per step


@dataclass(frozen=True)
class RecorderHead:
    """A recorder's fixed-size state: its settings and counters, none of the rows that grow."""

    ids: NDArray[np.int64]
    trace_ids: NDArray[np.int64] | None  # as given to the constructor (None: every aMussel)
    max_trace_bytes: int
    active_steps: NDArray[np.int64]
    n_steps: int
    trace_stride: int
    sinking_counts_active: bool
    times: StateTimes
    last_us: int  # mission time of the last state recorded (or the start)
    samples_taken: NDArray[np.int64] | None = None  # (n,) as the last state recorded said; None: zeros
    samples_due: NDArray[np.int64] | None = None
    max_trace_rows: int = DEFAULT_MAX_TRACE_ROWS
    days: DayLedger | None = None  # a copy; None: no per-day figures
    start_us: int | None = None  # mission time before the first step; None: a checkpoint from before it was kept
    n_rows: int | None = None  # step rows kept (event steps: fewer than n_steps); None: n_steps


@dataclass(frozen=True)
class RecorderRows:
    """Rows of a recorder from some step on: one per step, and the battery trace rows of those steps."""

    time_us: NDArray[np.int64]  # (m,) mission time at the end of each step
    active_count: NDArray[np.int32]  # (m,)
    trace_steps: NDArray[np.int64]  # (j,) step index of each trace row, increasing
    trace: NDArray[np.float32]  # (j, n_trace) battery fraction
    trace_state: NDArray[np.uint8] | None = None  # (j, n_trace) MusselState; None: not recorded (all ACTIVE)
    trace_rows: NDArray[np.int64] | None = None  # (j,) the step row of each trace row; None: its step (lockstep)


class Recorder:
    """Feed it every state a run produces (`record`, after each step); read results any time."""

    def __init__(
        self,
        ids: ArrayLike,
        trace_every_steps: int = 1,
        trace_ids: ArrayLike | None = None,
        max_trace_bytes: int = DEFAULT_MAX_TRACE_BYTES,
        sinking_counts_active: bool = True,
        start_us: int = 0,
        max_trace_rows: int = DEFAULT_MAX_TRACE_ROWS,
        day_us: int | None = None,
    ) -> None:
        """`start_us`: mission time of the state before the first step (a step's length, when
        `record` is not told it, is the time since the state recorded before); `day_us`: mission time
        of one simulated day (`day_ledger.day_us(theta)`), None: no per-day figures."""
        self.ids = np.asarray(ids, np.int64)
        self.sinking_counts_active = sinking_counts_active
        self._counts = np.zeros(N_STATES, bool)  # MusselState -> counts as active
        self._counts[ACTIVE] = True
        self._counts[SINKING] = sinking_counts_active
        self.times = StateTimes.zeros(self.ids.size)
        self.start_us = int(start_us)  # mission time of the state before the first step
        self._last_us = int(start_us)
        self._alive = LastMade(_alive)  # a state array is read-only: counted once
        self._trace_ids_arg = None if trace_ids is None else np.asarray(trace_ids, np.int64)
        self._max_trace_bytes = int(max_trace_bytes)
        self._max_trace_rows = int(max_trace_rows)
        self.days = DayLedger(int(day_us), int(start_us)) if day_us is not None else None
        n = self.ids.size
        self.active_steps = np.zeros(n, np.int64)  # (n,) steps each agent ended active
        self.samples_taken = np.zeros(n, np.int64)  # (n,) wakes ACTIVE on the seabed (the last state's count)
        self.samples_due = np.zeros(n, np.int64)  # (n,) wakes of its schedule
        self.n_steps = 0  # steps of the model's period (a step of k periods counts k)
        self.n_rows = 0  # step rows: one per step recorded, and one per trace row inside a longer step
        self._active_count = np.zeros(1024, np.int32)  # (capacity,) grows by doubling
        self._time_us = np.zeros(1024, np.int64)
        if trace_ids is None:
            self._trace_cols: NDArray[np.intp] | None = None
            n_trace = n
        else:
            want = np.asarray(trace_ids, np.int64)
            cols = np.searchsorted(self.ids, want)
            if (cols >= n).any() or not np.array_equal(self.ids[np.minimum(cols, n - 1)], want):
                raise ValueError("trace_ids must be ids of the fleet")
            self._trace_cols = cols
            n_trace = want.size
        self.trace_ids = self.ids if self._trace_cols is None else self.ids[self._trace_cols]
        self.trace_stride = int(trace_every_steps)
        self._row_bytes = max(n_trace * (np.dtype(np.float32).itemsize + 1), 1)  # battery float32, state uint8
        self._max_rows = max(min(int(max_trace_bytes // self._row_bytes), self._max_trace_rows), 2)
        self._trace_rows: list[NDArray[np.float32]] = []
        self._state_rows: list[NDArray[np.uint8]] = []
        self._trace_steps: list[int] = []  # the step index of each trace row (multiples of the stride)
        self._trace_at: list[int] = []  # its step row (the same as its step unless steps were longer)

    def record(self, state: FleetState, dt_us: int | None = None, periods: int = 1,
               before: FleetState | None = None) -> None:
        """Count one step of `dt_us` (default: since the last state recorded) that ended in `state`
        (state.ids must be this recorder's ids), as `periods` steps of the model's period (the event
        platform's longer steps, over which nothing changed discontinuously: the state constant, the
        battery linear from `before`'s, which traces the steps inside it; `next_change`)."""
        dt_us = state.time_us - self._last_us if dt_us is None else dt_us
        newly_depleted = self.times.add(state.state, dt_us)
        start_us, self._last_us = self._last_us, state.time_us
        self.samples_taken, self.samples_due = state.samples_taken, state.samples_due  # read-only: no copy
        active = self._counts[state.state]
        if periods == 1:
            self.active_steps += active
        else:
            self.active_steps += active * np.int64(periods)
        n_active = int(np.count_nonzero(active))
        k = self.n_steps
        if periods > 1 and self.trace_stride > 0:
            self._trace_inside(state, before, k, periods, start_us, dt_us, n_active)
        last = k + periods - 1  # the step index of the step's last period
        row = self._add_row(state.time_us, n_active)
        self.n_steps = k + periods
        if self.days is not None:
            self.days.add(state.time_us, n_active, self._alive(state.state), newly_depleted, periods)
        if self.trace_stride > 0 and last % self.trace_stride == 0:
            if len(self._trace_rows) >= self._max_rows:
                self._decimate()
            if last % self.trace_stride == 0:
                self._trace(state.battery_frac, state.state, last, row)

    def _add_row(self, time_us: int, n_active: int) -> int:
        r = self.n_rows
        if r == self._active_count.size:
            self._active_count = np.concatenate([self._active_count, np.zeros_like(self._active_count)])
            self._time_us = np.concatenate([self._time_us, np.zeros_like(self._time_us)])
        self._active_count[r] = n_active
        self._time_us[r] = time_us
        self.n_rows = r + 1
        return r

    def _trace(self, battery: NDArray[np.float64], state: NDArray[np.uint8], step: int, row: int) -> None:
        cols = self._trace_cols
        u = battery if cols is None else battery[cols]
        self._trace_rows.append(u.astype(np.float32))
        self._state_rows.append(state.copy() if cols is None else state[cols])
        self._trace_steps.append(step)
        self._trace_at.append(row)

    def _trace_inside(self, state: FleetState, before: FleetState | None, k: int, periods: int, start_us: int,
                      dt_us: int, n_active: int) -> None:
        """The trace rows of the periods k .. k + periods - 2 of a longer step (its last is the step's
        own), each with a step row of its own at its instant: the battery linear between `before`'s and
        `state`'s, the state and the active count the step's (constant over it)."""
        u0 = state.battery_frac if before is None else before.battery_frac
        du = state.battery_frac - u0
        j = -(-k // self.trace_stride) * self.trace_stride
        while j < k + periods - 1:
            if len(self._trace_rows) >= self._max_rows:
                self._decimate()
                j = -(-j // self.trace_stride) * self.trace_stride
                continue
            done = j - k + 1  # periods of the step at the end of period j
            row = self._add_row(start_us + dt_us * done // periods, n_active)
            self._trace(u0 + du * (done / periods), state.state, j, row)
            j += self.trace_stride

    def _decimate(self) -> None:
        self.trace_stride *= 2
        keep = [i for i, s in enumerate(self._trace_steps) if s % self.trace_stride == 0]
        self._trace_rows = [self._trace_rows[i] for i in keep]
        self._state_rows = [self._state_rows[i] for i in keep]
        self._trace_steps = [self._trace_steps[i] for i in keep]
        self._trace_at = [self._trace_at[i] for i in keep]

    def head(self) -> RecorderHead:
        """The fixed-size state (a copy): what `restore` needs besides the rows."""
        return RecorderHead(self.ids, self._trace_ids_arg, self._max_trace_bytes, self.active_steps.copy(),
                            self.n_steps, self.trace_stride, self.sinking_counts_active, self.times.copy(),
                            self._last_us, self.samples_taken.copy(), self.samples_due.copy(), self._max_trace_rows,
                            self.days.copy() if self.days is not None else None, self.start_us,
                            None if self.n_rows == self.n_steps else self.n_rows)

    def rows_since(self, k: int) -> RecorderRows:
        """The step rows k, k + 1, ... recorded so far and the trace rows at them (copies; trace rows
        only as kept now). In lockstep a step row is a step."""
        if not 0 <= k <= self.n_rows:
            raise ValueError(f"step {k} is outside 0..{self.n_rows}")
        j = bisect_left(self._trace_at, k)
        steps, trace, trace_state = self._traces(j)
        at = np.asarray(self._trace_at[j:], np.int64)
        return RecorderRows(self._time_us[k: self.n_rows].copy(), self._active_count[k: self.n_rows].copy(),
                            steps, trace, trace_state, None if np.array_equal(at, steps) else at)

    def _traces(self, j: int = 0) -> tuple[NDArray[np.int64], NDArray[np.float32], NDArray[np.uint8]]:
        """The trace rows kept, from the j-th on: (steps `(k,)`, battery `(k, n_trace)`, state `(k, n_trace)`)."""
        n = self.trace_ids.size
        steps = np.asarray(self._trace_steps[j:], np.int64)
        if j >= len(self._trace_rows):
            return steps, np.zeros((0, n), np.float32), np.zeros((0, n), np.uint8)
        return steps, np.stack(self._trace_rows[j:]), np.stack(self._state_rows[j:])

    @classmethod
    def restore(cls, head: RecorderHead, rows: RecorderRows) -> Recorder:
        """The recorder `head` came from, given its rows since step 0 (ValueError if they do not fit).

        `rows.trace` may hold rows that were decimated since they were taken: they are dropped here.
        """
        rec = cls(head.ids, 1, head.trace_ids, head.max_trace_bytes, head.sinking_counts_active, head.last_us,
                  head.max_trace_rows)
        rec.days = head.days.copy() if head.days is not None else None
        rec.start_us = int(head.start_us) if head.start_us is not None else 0
        n = int(head.n_steps)
        n_rows = n if head.n_rows is None else int(head.n_rows)
        if head.active_steps.shape != rec.ids.shape or n < 0 or int(head.trace_stride) < 0:
            raise ValueError("recorder head does not fit its ids")
        if head.times.state_us.shape != rec.times.state_us.shape:
            raise ValueError("recorder head's state times do not fit its ids")
        rec.times = head.times.copy()
        if rows.time_us.shape != (n_rows,) or rows.active_count.shape != (n_rows,):
            raise ValueError(f"{rows.time_us.size} step rows for {n_rows} steps")
        steps = np.asarray(rows.trace_steps, np.int64)
        if rows.trace.shape != (steps.size, rec.trace_ids.size):
            raise ValueError("trace rows do not fit the traced aMussels")
        states = rows.trace_state if rows.trace_state is not None else np.full(rows.trace.shape, ACTIVE, np.uint8)
        if states.shape != rows.trace.shape:
            raise ValueError("trace state rows do not fit the battery rows")
        if steps.size and (steps[0] < 0 or steps[-1] >= n or (np.diff(steps) <= 0).any()):
            raise ValueError("trace rows are not in step order")
        at = steps if rows.trace_rows is None else np.asarray(rows.trace_rows, np.int64)
        if at.shape != steps.shape or (at.size and (at[0] < 0 or at[-1] >= n_rows or (np.diff(at) <= 0).any())):
            raise ValueError("trace rows do not fit the step rows")
        rec.active_steps = np.array(head.active_steps, np.int64)
        for name in ("samples_taken", "samples_due"):
            counts = getattr(head, name)
            if counts is not None:
                if np.shape(counts) != rec.ids.shape:
                    raise ValueError(f"recorder head's {name} does not fit its ids")
                setattr(rec, name, np.array(counts, np.int64))
        rec.n_steps, rec.n_rows = n, n_rows
        rec.trace_stride = int(head.trace_stride)
        capacity = max(1024, 1 << max(n_rows - 1, 0).bit_length())
        rec._active_count = np.zeros(capacity, np.int32)
        rec._time_us = np.zeros(capacity, np.int64)
        rec._active_count[:n_rows] = rows.active_count
        rec._time_us[:n_rows] = rows.time_us
        if rec.trace_stride > 0:
            keep = steps % rec.trace_stride == 0
            kept = np.ascontiguousarray(rows.trace[keep], np.float32)
            rec._trace_rows = list(kept)
            rec._state_rows = list(np.ascontiguousarray(states[keep], np.uint8))
            rec._trace_steps = steps[keep].tolist()
            rec._trace_at = at[keep].tolist()
        if len(rec._trace_rows) > rec._max_rows:
            raise ValueError("more trace rows than the recorder's budget")
        return rec

    def uptime_pct(self) -> NDArray[np.float64]:
        """Eq. (3): 100 * active steps / all steps, per agent `(n,)` (SINKING is active if it counts)."""
        if self.n_steps == 0:
            return np.zeros(self.ids.size)
        return 100.0 * self.active_steps / self.n_steps

    def samples(self) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """(samples taken, samples scheduled) per agent `(n,)`: the wakes of its schedule at which it
        was ACTIVE on the seabed, and all of them (both 0 for an always-on agent)."""
        return self.samples_taken.copy(), self.samples_due.copy()

    def active_count(self) -> NDArray[np.int32]:
        """Number of aMussels active (ACTIVE, or SINKING if it counts) at the end of each step row `(n_rows,)`
        (lockstep: each step; longer steps: each, and each trace row's instant inside one)."""
        return self._active_count[: self.n_rows].copy()

    def step_time_us(self) -> NDArray[np.int64]:
        """Mission time at the end of each step row `(n_rows,)`."""
        return self._time_us[: self.n_rows].copy()

    def battery_trace(self) -> tuple[NDArray[np.int64], NDArray[np.float32]]:
        """(step rows `(k,)` (0 = the first; index `step_time_us`, `active_count`), battery u `(k, n_trace)`
        float32). In lockstep a step row is the step index."""
        _, battery, _ = self._traces()
        return np.asarray(self._trace_at, np.int64), battery

    def state_trace(self) -> tuple[NDArray[np.int64], NDArray[np.uint8]]:
        """(step rows `(k,)`, MusselState `(k, n_trace)` uint8) at the same rows as `battery_trace`."""
        _, _, state = self._traces()
        return np.asarray(self._trace_at, np.int64), state

    @property
    def max_trace_rows(self) -> int:
        """The most trace rows kept at any time, whatever the mission's length."""
        return self._max_rows

    def summary(self) -> UptimeSummary:
        up = self.uptime_pct()
        counts = self.active_count()
        return UptimeSummary(
            n_steps=self.n_steps,
            avg_uptime_pct=float(up.mean()) if up.size else 0.0,
            max_uptime_pct=float(up.max()) if up.size else 0.0,
            min_uptime_pct=float(up.min()) if up.size else 0.0,
            avg_active=(float(counts.mean()) if self.n_rows == self.n_steps  # lockstep: as ever
                        else float(self.active_steps.sum()) / self.n_steps) if counts.size else 0.0,
        )


def _alive(state: NDArray[np.uint8]) -> int:
    """How many aMussels are not depleted."""
    return int(np.count_nonzero(state != DEPLETED))
