"""Activity log of a run: uptime per eq. (3), active count per step, battery traces.

Per-agent counters and per-step scalars cost O(n) and O(steps) memory, so they are always kept.
Battery traces cost O(n * steps): 100,000 aMussels for a 40 min run at 1 Hz would be 0.96 GB as
float32. So traces have a memory budget (`max_trace_bytes`, default 64 MiB): when the next row
would exceed it, every other stored row is dropped and the sampling stride doubles. The kept rows
are always the steps that are multiples of the current stride, so a trace stays evenly sampled,
complete for small fleets (12 aMussels x 24 h at 1 Hz is 4 MB) and bounded for large ones.
`trace_every_steps=0` turns traces off; `trace_ids` restricts them to some aMussels.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mussel_sim.fleet import ACTIVE, FleetState

DEFAULT_MAX_TRACE_BYTES = 64 * 2**20


@dataclass(frozen=True)
class UptimeSummary:
    """The paper's Table II columns for the aMussels (uptime in %, eq. (3))."""

    n_steps: int
    avg_uptime_pct: float
    max_uptime_pct: float
    min_uptime_pct: float
    avg_active: float  # mean number of active aMussels per step


class Recorder:
    """Feed it every state a run produces (`record`, after each step); read results any time."""

    def __init__(
        self,
        ids: ArrayLike,
        trace_every_steps: int = 1,
        trace_ids: ArrayLike | None = None,
        max_trace_bytes: int = DEFAULT_MAX_TRACE_BYTES,
    ) -> None:
        self.ids = np.asarray(ids, np.int64)
        n = self.ids.size
        self.active_steps = np.zeros(n, np.int64)  # (n,) steps each agent ended ACTIVE
        self.n_steps = 0
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
        self._row_bytes = max(n_trace * np.dtype(np.float32).itemsize, 1)
        self._max_rows = max(int(max_trace_bytes // self._row_bytes), 2)
        self._trace_rows: list[NDArray[np.float32]] = []
        self._trace_steps: list[int] = []

    def record(self, state: FleetState) -> None:
        """Count one step that ended in `state` (state.ids must be this recorder's ids)."""
        active = state.state == ACTIVE
        self.active_steps += active
        k = self.n_steps
        if k == self._active_count.size:
            self._active_count = np.concatenate([self._active_count, np.zeros_like(self._active_count)])
            self._time_us = np.concatenate([self._time_us, np.zeros_like(self._time_us)])
        self._active_count[k] = int(np.count_nonzero(active))
        self._time_us[k] = state.time_us
        self.n_steps = k + 1
        if self.trace_stride > 0 and k % self.trace_stride == 0:
            if len(self._trace_rows) >= self._max_rows:
                self._decimate()
            if k % self.trace_stride == 0:
                u = state.battery_frac if self._trace_cols is None else state.battery_frac[self._trace_cols]
                self._trace_rows.append(u.astype(np.float32))
                self._trace_steps.append(k)

    def _decimate(self) -> None:
        self.trace_stride *= 2
        keep = [i for i, s in enumerate(self._trace_steps) if s % self.trace_stride == 0]
        self._trace_rows = [self._trace_rows[i] for i in keep]
        self._trace_steps = [self._trace_steps[i] for i in keep]

    def uptime_pct(self) -> NDArray[np.float64]:
        """Eq. (3): 100 * active steps / all steps, per agent `(n,)`."""
        if self.n_steps == 0:
            return np.zeros(self.ids.size)
        return 100.0 * self.active_steps / self.n_steps

    def active_count(self) -> NDArray[np.int32]:
        """Number of ACTIVE aMussels at the end of each step `(n_steps,)`."""
        return self._active_count[: self.n_steps].copy()

    def step_time_us(self) -> NDArray[np.int64]:
        """Mission time at the end of each step `(n_steps,)`."""
        return self._time_us[: self.n_steps].copy()

    def battery_trace(self) -> tuple[NDArray[np.int64], NDArray[np.float32]]:
        """(step indices `(k,)` (0 = first recorded step), battery u `(k, n_trace)` float32)."""
        steps = np.asarray(self._trace_steps, np.int64)
        if not self._trace_rows:
            return steps, np.zeros((0, self.trace_ids.size), np.float32)
        return steps, np.stack(self._trace_rows)

    def summary(self) -> UptimeSummary:
        up = self.uptime_pct()
        counts = self.active_count()
        return UptimeSummary(
            n_steps=self.n_steps,
            avg_uptime_pct=float(up.mean()) if up.size else 0.0,
            max_uptime_pct=float(up.max()) if up.size else 0.0,
            min_uptime_pct=float(up.min()) if up.size else 0.0,
            avg_active=float(counts.mean()) if counts.size else 0.0,
        )
