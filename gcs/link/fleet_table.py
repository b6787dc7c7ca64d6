"""The aMussel table: the latest status heard from every aMussel, simulated or real, as columns.

A fleet of hundreds reports every few seconds, so the table is numpy columns `(n,)` in the order ids
were first heard, updated one report at a time (a real node) or a whole batch at once (the
simulated fleet in the same process). Reads by id build a `MusselView` on demand;
questions over the whole fleet (`select`) are vectorised.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from gcs.link.telemetry import DEG_E7, MAX_TIME_US, MusselView
from mussel_sim.vocabulary import MusselState

_N_STATES = len(MusselState)
_FEW = 8  # a batch this small is checked row by row


@dataclass(frozen=True)
class MusselBatch:
    """Many AMUSSEL_STATUS at once, one array `(n,)` per field (wire units)."""

    mussel_id: NDArray[np.integer]
    lat_e7: NDArray[np.integer]
    lon_e7: NDArray[np.integer]
    depth_m: NDArray[np.floating]
    battery_frac: NDArray[np.floating]
    battery_mv: NDArray[np.integer]
    state: NDArray[np.integer]
    simulated: NDArray[np.integer]
    time_us: NDArray[np.integer]

    def take(self, rows: NDArray[np.bool_]) -> MusselBatch:
        """The batch of the rows where `rows` is True."""
        return MusselBatch(*(getattr(self, f)[rows] for f in MusselBatch.__dataclass_fields__))

    @staticmethod
    def from_wire(fields: Mapping[str, Any]) -> MusselBatch:
        """From AMUSSEL_STATUS columns by their wire names (a scalar stands for every row)."""
        ids = np.asarray(fields["mussel_id"])
        n = ids.size

        def col(name: str, dtype: Any) -> NDArray[Any]:
            value = np.asarray(fields[name], dtype)
            return value if value.ndim else np.full(n, value)

        return MusselBatch(ids, col("lat", np.int64), col("lon", np.int64), col("depth", np.float64),
                           col("battery", np.float64), col("battery_voltage", np.int64), col("state", np.int64),
                           col("simulated", np.int64), col("time_us", np.uint64))


class MusselTable(Mapping[int, MusselView]):
    def __init__(self) -> None:
        self.ids = np.zeros(0, np.int64)
        self.lat_e7 = np.zeros(0, np.int64)
        self.lon_e7 = np.zeros(0, np.int64)
        self.depth_m = np.zeros(0)
        self.battery_frac = np.zeros(0)
        self.battery_mv = np.zeros(0, np.int64)
        self.state = np.zeros(0, np.uint8)
        self.simulated = np.zeros(0, bool)
        self.time_us = np.zeros(0, np.int64)
        self._row: dict[int, int] = {}
        self._last_ids: NDArray[np.integer] | None = None  # a batch of the same ids reuses its rows
        self._last_rows = np.zeros(0, np.intp)
        self._views: dict[int, MusselView] = {}  # built since the last update: a loop reads the same few often
        self.version = 0  # bumped on every update: readers cache what they derive from the table

    # --- updates -----------------------------------------------------------------------------

    def update(self, r: MusselView) -> str | None:
        """Take one report; or refuse it (the reason) when a real and a simulated aMussel share an id:
        the two can not be told apart, and neither may overwrite the other."""
        row = self._row.get(r.mussel_id)
        if row is not None and bool(self.simulated[row]) != r.simulated:
            return "AMUSSEL_STATUS.id_collision"
        if row is None:
            row = self._row[r.mussel_id] = len(self._row)
            self._grow(np.array([r.mussel_id], np.int64))
        self.lat_e7[row], self.lon_e7[row] = r.lat_e7, r.lon_e7
        self.depth_m[row], self.battery_frac[row], self.battery_mv[row] = r.depth_m, r.battery_frac, r.battery_mv
        self.state[row], self.simulated[row], self.time_us[row] = int(r.state), r.simulated, r.time_us
        self._views.pop(r.mussel_id, None)
        self.version += 1
        return None

    def update_batch(self, b: MusselBatch) -> Counter[str]:
        """Take every valid row of `b`; return the rejected rows counted by reason."""
        bad = batch_rejections(b)
        rejected = Counter({reason: int(mask.sum()) for reason, mask in bad.items() if mask.any()})
        if rejected:  # the rare case: keep the good rows
            b = b.take(~np.logical_or.reduce(list(bad.values())))
        known = len(self._row)
        rows = self._rows_of(b.mussel_id)
        clash = (rows < known) & (self.simulated[rows] != (b.simulated != 0))  # real vs simulated, one id
        if clash.any():
            rejected["AMUSSEL_STATUS.id_collision"] += int(clash.sum())
            rows, b = rows[~clash], b.take(~clash)
        self.lat_e7[rows], self.lon_e7[rows], self.depth_m[rows] = b.lat_e7, b.lon_e7, b.depth_m
        self.battery_frac[rows], self.battery_mv[rows] = b.battery_frac, b.battery_mv
        self.state[rows], self.simulated[rows], self.time_us[rows] = b.state, b.simulated, b.time_us
        self._views.clear()
        self.version += 1
        return rejected

    def moved(self, ids: NDArray[np.integer], lat_e7: NDArray[np.int64], lon_e7: NDArray[np.int64]) -> None:
        """Where aMussels already heard are now, all else as reported (the event platform's ideal link hands
        over the positions lockstep's keep-alive repeats carry: `mussel_sim.keepalive_positions`). Not news: a
        wait reads positions only when it looks, and they are brought up to date then (`version` kept: what
        is derived from the rest of the table stands)."""
        known = np.isin(ids, self.ids)
        rows = self._rows_of(np.asarray(ids)[known])
        self.lat_e7[rows], self.lon_e7[rows] = lat_e7[known], lon_e7[known]
        self._views.clear()

    def load(self, saved: MusselTable) -> None:
        """Take a saved table's contents (a resumed mission); whoever holds this table keeps it."""
        self.__dict__.update(saved.__dict__)
        self._views = {}  # a table saved before views were kept has none
        self.version += 1

    def _rows_of(self, ids: NDArray[np.integer]) -> NDArray[np.intp]:
        last = self._last_ids
        if last is not None and last.shape == ids.shape and np.array_equal(last, ids):
            return self._last_rows
        new = [int(i) for i in ids if int(i) not in self._row]
        if new:
            for i in dict.fromkeys(new):
                self._row[i] = len(self._row)
            self._grow(np.array(list(dict.fromkeys(new)), np.int64))
        rows = np.fromiter((self._row[int(i)] for i in ids), np.intp, ids.size)
        self._last_ids, self._last_rows = ids.copy(), rows
        return rows

    def _grow(self, new_ids: NDArray[np.int64]) -> None:
        k = new_ids.size
        self.ids = np.concatenate([self.ids, new_ids])
        for name, dtype in (("lat_e7", np.int64), ("lon_e7", np.int64), ("depth_m", float), ("battery_frac", float),
                            ("battery_mv", np.int64), ("state", np.uint8), ("simulated", bool), ("time_us", np.int64)):
            setattr(self, name, np.concatenate([getattr(self, name), np.zeros(k, dtype)]))

    # --- reads -------------------------------------------------------------------------------

    def __getitem__(self, mussel_id: int) -> MusselView:
        view = self._views.get(mussel_id)
        if view is None:
            k = self._row[mussel_id]  # KeyError: never heard
            view = self._views[mussel_id] = MusselView(
                mussel_id, int(self.lat_e7[k]), int(self.lon_e7[k]), float(self.depth_m[k]),
                float(self.battery_frac[k]), int(self.battery_mv[k]), MusselState(int(self.state[k])),
                bool(self.simulated[k]), int(self.time_us[k]),
            )
        return view

    def __iter__(self) -> Iterator[int]:
        return iter(self._row)

    def __len__(self) -> int:
        return len(self._row)

    def rows(self, ids: NDArray[np.integer]) -> NDArray[np.intp]:
        """The table row of each id `(n,)`; -1 where the id was never heard."""
        return np.fromiter((self._row.get(int(i), -1) for i in ids), np.intp, ids.size)

    def __contains__(self, mussel_id: object) -> bool:
        return mussel_id in self._row

    def select(self, states: tuple[MusselState, ...], battery_below: float | None = None) -> list[int]:
        """Ids in one of `states` (and below a battery fraction), lowest id first."""
        wanted = np.zeros(256, bool)  # a lookup by state (np.isin is made for large sets)
        wanted[[int(s) for s in states]] = True
        mask = wanted[self.state]
        if battery_below is not None:
            mask &= self.battery_frac < battery_below
        return np.sort(self.ids[mask]).tolist()


def batch_rejections(b: MusselBatch) -> dict[str, NDArray[np.bool_]]:
    """Per reason, the rows of a batch that fail validation (the rules of `telemetry._mussel`); none at
    all (an empty dict) when every row is valid, which a dozen reductions tell (a NaN fails them too)."""
    if b.mussel_id.size and _all_valid(b):
        return {}
    lat_lon_bad = (np.abs(b.lat_e7) > 90 * DEG_E7) | (np.abs(b.lon_e7) > 180 * DEG_E7)
    with np.errstate(invalid="ignore"):
        level_bad = ~(np.isfinite(b.depth_m) & np.isfinite(b.battery_frac) & (b.battery_frac >= 0.0)
                      & (b.battery_frac <= 1.0) & (b.depth_m >= 0.0))
    return {
        "AMUSSEL_STATUS.mussel_id": b.mussel_id <= 0,
        "AMUSSEL_STATUS.lat_lon": lat_lon_bad,
        "AMUSSEL_STATUS.battery_depth": level_bad,
        "AMUSSEL_STATUS.state": (b.state < 0) | (b.state >= _N_STATES),
        "AMUSSEL_STATUS.simulated": (b.simulated < 0) | (b.simulated > 1),
        "AMUSSEL_STATUS.time_us": b.time_us > MAX_TIME_US,
    }


def _all_valid(b: MusselBatch) -> bool:
    """True if no row fails `batch_rejections`' rules: the fleet's every batch, checked in reductions (a
    batch of a few rows, what a fleet reporting by exception mostly sends, row by row: a dozen numpy
    reductions cost more than looking at them)."""
    lim = 90 * DEG_E7
    if b.mussel_id.size <= _FEW:
        return all(
            mussel_id > 0 and abs(lat) <= lim and abs(lon) <= 2 * lim and 0.0 <= depth < math.inf
            and 0.0 <= battery <= 1.0 and 0 <= state < _N_STATES and 0 <= simulated <= 1 and time_us <= MAX_TIME_US
            for mussel_id, lat, lon, depth, battery, state, simulated, time_us in zip(
                b.mussel_id.tolist(), b.lat_e7.tolist(), b.lon_e7.tolist(), b.depth_m.tolist(),
                b.battery_frac.tolist(), b.state.tolist(), b.simulated.tolist(), b.time_us.tolist(), strict=True)
        )
    return bool(
        b.mussel_id.min() > 0 and np.abs(b.lat_e7).max() <= lim and np.abs(b.lon_e7).max() <= 2 * lim
        and b.depth_m.min() >= 0.0 and b.depth_m.max() < np.inf
        and b.battery_frac.min() >= 0.0 and b.battery_frac.max() <= 1.0
        and b.state.min() >= 0 and b.state.max() < _N_STATES
        and b.simulated.min() >= 0 and b.simulated.max() <= 1 and b.time_us.max() <= MAX_TIME_US
    )
