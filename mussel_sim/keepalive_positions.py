"""The keep-alive's positions on the event platform: where lockstep's GCS would know each drifting aMussel to be.

Lockstep's fleet repeats every speaking aMussel's status at the first publish of each keep-alive window
(`report_policy`), so its GCS knows where a drifting aMussel was at the window's start; the battery and the
state in those repeats it foresees anyway (`gcs.belief.foresight`), the position it cannot (the drift is
random). The event platform's fleet sends no keep-alive: what its GCS would lack is the position. Since a
long step draws the drift of each of its periods in order (`drift.summed_drift_m`), the position at any
step instant is known without taking the step: the draws from the model's time to it, from a copy of the
stream (the step that follows draws the same ones). So the GCS is handed, when it reads positions
(`VehicleRegistry.refresh_positions`, the ideal link's hand-over without signalling), the position at the
start of the current window of every aMussel lockstep's repeat would have carried: speaking then (awake;
in an acoustic scenario at the surface), not depleted, not reported since, not docked (a docked one is
where its aPad is, which the GCS knows). A step that crosses a window's start leaves the positions there
first (`before_step`), for a read after it.

Pure but for the random stream it copies: the runner passes its state, stream and parameters.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from mussel_sim.comms_config import SURFACE_DEPTH_M
from mussel_sim.drift import NoCurrent, summed_drift_m
from mussel_sim.fleet_sleep import publish_rows
from mussel_sim.fleet_state import DOCKED, FleetParams, FleetState
from mussel_sim.geo import LocalFrame
from mussel_sim.vocabulary import MusselState

# (ids, lat_e7, lon_e7): positions for the GCS's table
Deliver = Callable[[NDArray[np.integer], NDArray[np.int64], NDArray[np.int64]], None]


class KeepAlivePositions:
    """The keep-alive windows (every `keepalive_us` of mission time; the fleet steps every `period_us`) and
    what the GCS was last handed."""

    def __init__(self, n: int, keepalive_us: int, period_us: int, frame: LocalFrame, at_surface_only: bool) -> None:
        self.keepalive_us = max(keepalive_us, period_us)  # 0: a repeat at every publish
        self.period_us = period_us
        self.frame = frame
        self.at_surface_only = at_surface_only
        self.deliver: Deliver | None = None  # set by whoever wires the GCS to the fleet (the event platform's world)
        self.said_us = np.full(n, -1, np.int64)  # each aMussel's last status, stamped
        self._done_us = -1  # the window last handed over
        self._kept: tuple[int, NDArray[np.float64], NDArray[np.float64]] | None = None  # (window, x, y) before a step
        self._peek: tuple[int, np.random.Generator, int, NDArray[np.float64]] | None = None  # (from, copy, steps, sum)

    def said(self, rows: NDArray[np.intp] | None, time_us: int) -> None:
        """Statuses of `rows` (None: all) went out, stamped `time_us`."""
        if rows is None:
            self.said_us[:] = time_us
        else:
            self.said_us[rows] = time_us

    def window_us(self, now_us: int) -> int:
        """The start of the keep-alive window `now_us` is in (a multiple of the window: lockstep's phase)."""
        return now_us - now_us % self.keepalive_us

    def before_step(self, state: FleetState, to_us: int, rng: np.random.Generator, params: FleetParams) -> None:
        """A step from `state` to `to_us` is about to be taken: if it crosses a window's start (short of its
        end), the positions there are kept."""
        w = self.window_us(to_us)
        if state.time_us <= w < to_us:
            x, y = self._positions_at(state, w, rng, params)
            self._kept = (w, x, y)

    def refresh(self, now_us: int, state: FleetState, rng: np.random.Generator, params: FleetParams) -> None:
        """The GCS reads positions at `now_us`: hand it those of the window's start it has not had."""
        w = self.window_us(now_us)
        if w <= self._done_us or self.deliver is None:
            return
        self._done_us = w
        if self._kept is not None and self._kept[0] == w and state.time_us > w:
            _, x, y = self._kept
        else:  # the model at or before the window's start (a step past it keeps its positions there first)
            x, y = self._positions_at(state, w, rng, params)
        rows = self._rows(state, w, params.theta)
        if rows.size:
            lat, lon = self.frame.to_geodetic(x[rows], y[rows])
            self.deliver(state.ids[rows], np.round(np.atleast_1d(lat) * 1e7).astype(np.int64),
                         np.round(np.atleast_1d(lon) * 1e7).astype(np.int64))

    def _rows(self, state: FleetState, w: int, theta: float) -> NDArray[np.intp]:
        speaking = publish_rows(state, theta, w - self.period_us, w)  # None: all
        mask = np.ones(state.n, bool)
        if speaking is not None:
            mask[:] = False
            mask[speaking] = True
        mask &= (state.state != DOCKED) & (state.state != MusselState.DEPLETED) & (self.said_us < w)
        if self.at_surface_only:
            mask &= state.depth_m <= SURFACE_DEPTH_M
        return np.flatnonzero(mask)

    def _positions_at(self, state: FleetState, w: int, rng: np.random.Generator, params: FleetParams
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Where the model's steps from `state` to the step instant `w` leave the aMussels that are not docked
        (nothing changes between the model's steps but the batteries and the drift)."""
        steps = (w - state.time_us) // self.period_us
        x, y = state.x_m.copy(), state.y_m.copy()
        if steps <= 0:
            return x, y
        if not isinstance(params.current, NoCurrent):
            ve, vn = params.current.velocity_mps(state.x_m, state.y_m, state.time_s)
            x += ve * steps * self.period_us / 1e6
            y += vn * steps * self.period_us / 1e6
        if params.drift_half_width_m > 0:
            drift = self._drift(state, steps, rng, params.drift_half_width_m)
            x += drift[0]
            y += drift[1]
        docked = state.state == DOCKED
        x[docked], y[docked] = state.x_m[docked], state.y_m[docked]
        return x, y

    def _drift(self, state: FleetState, steps: int, rng: np.random.Generator, half: float) -> NDArray[np.float64]:
        """The drift of the model's next `steps` steps from `state`, summed: drawn from a copy of the stream,
        kept and extended while the model stays at `state`'s time."""
        peek = self._peek
        if peek is None or peek[0] != state.time_us or peek[2] > steps:
            copy = np.random.Generator(type(rng.bit_generator)())
            copy.bit_generator.state = rng.bit_generator.state
            peek = (state.time_us, copy, 0, np.zeros((2, state.n)))
        start, copy, drawn, total = peek
        if steps > drawn:
            total = total + summed_drift_m(copy, state.n, half, steps - drawn)
        self._peek = (start, copy, steps, total)
        return total
