"""The model's columns: append-only history rows, and the latest report of each aMussel."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from gcs.link.fleet_table import MusselTable
from gcs.link.telemetry import DEG_E7
from mussel_sim.vocabulary import MusselState


class Growing:
    """Append-only rows; written rows never change, so views of them are safe to hand out."""

    def __init__(self, width: int, dtype: Any, fill: float = 0.0) -> None:
        self.fill = fill
        self.data = np.full((256, width) if width else (256,), fill, dtype)
        self.n = 0

    def append(self, row: Any) -> None:
        if self.n == self.data.shape[0]:
            bigger = np.full((2 * self.n, *self.data.shape[1:]), self.fill, self.data.dtype)
            bigger[: self.n] = self.data
            self.data = bigger  # old views keep the old buffer
        self.data[self.n] = row
        self.n += 1

    def widen(self, width: int) -> None:
        grown = np.full((self.data.shape[0], width), self.fill, self.data.dtype)
        grown[:, : self.data.shape[1]] = self.data
        self.data = grown

    def rows(self, k: int | None = None) -> NDArray[Any]:
        return self.data[: self.n if k is None else k]


@dataclass(frozen=True)
class FleetColumns:
    """The latest report of each aMussel, `(n,)` in a given id order; NaN / ACTIVE / -1 where never heard."""

    lat_deg: NDArray[np.float64]
    lon_deg: NDArray[np.float64]
    battery_frac: NDArray[np.float64]
    state: NDArray[np.uint8]
    report_us: NDArray[np.int64]  # when the report was made (a simulated aMussel's: our clock); -1: never
    simulated: NDArray[np.bool_]

    @staticmethod
    def of(table: MusselTable, ids: NDArray[np.int64]) -> FleetColumns:
        n = ids.size
        lat, lon, battery = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan)
        state = np.full(n, MusselState.ACTIVE, np.uint8)
        report_us, simulated = np.full(n, -1, np.int64), np.ones(n, bool)
        rows = table.rows(ids)
        heard = rows >= 0
        if heard.any():
            rows = rows[heard]
            lat[heard] = table.lat_e7[rows] / DEG_E7
            lon[heard] = table.lon_e7[rows] / DEG_E7
            battery[heard] = table.battery_frac[rows]
            state[heard] = table.state[rows]
            report_us[heard] = table.time_us[rows]
            simulated[heard] = table.simulated[rows] != 0
        return FleetColumns(lat, lon, battery, state, report_us, simulated)
