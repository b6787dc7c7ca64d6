"""Each aPad over a mission of any length, at a bounded cost: its track and its energy per simulated day.

The track is what the GCS heard (position and movement cost, as a replay of its log would show),
sampled once per `TRACK_PERIOD_S` of mission time and thinned as the recorder thins its traces: at
most `max_rows` samples, evenly spaced (when full, every other one goes and the stride doubles),
whatever the mission's length. The energy an embedded SITL aPad passed into aMussels, drew from its
battery and took in at home is read at each simulated day's end (`DayLedger`'s days, exactly on
the boundary: a task of the mission clock), so the figures per day are differences of exact
counters; a real aPad's counters are on the aPad. A console mission restored from a checkpoint
starts its track at the restore (`complete` is then False), and its energy per day is unknown (NaN,
left out of result.json) for the days up to the first boundary after it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from gcs.results.days import ENERGY_KEYS
from missiontime import US_PER_S, seconds_to_us
from missiontime.event_clock import EventClock

if TYPE_CHECKING:
    from gcs.mission.world import World

TRACK_PERIOD_S = 1.0  # as a replay samples a log
DEFAULT_MAX_TRACK_ROWS = 8192


class ThinnedSeries:
    """Rows offered at sample indices 0, 1, 2, ...; kept: those at multiples of the stride, at most
    `max_rows` (a full store drops every other row and doubles the stride)."""

    def __init__(self, width: int, max_rows: int) -> None:
        self.width = width
        self.max_rows = max(int(max_rows), 2)
        self.stride = 1
        self.index: list[int] = []
        self.rows: list[list[float]] = []

    def offer(self, k: int, row: list[float]) -> None:
        if k % self.stride:
            return
        if len(self.rows) >= self.max_rows:
            self.stride *= 2
            keep = [i for i, j in enumerate(self.index) if j % self.stride == 0]
            self.index = [self.index[i] for i in keep]
            self.rows = [self.rows[i] for i in keep]
            if k % self.stride:
                return
        self.index.append(k)
        self.rows.append(row)

    def array(self) -> NDArray[np.float64]:
        """The rows kept `(k, width)`."""
        return np.array(self.rows, np.float64).reshape(len(self.rows), self.width)


@dataclass
class ApadRecord:
    """The aPads' (`apad_ids`, in order) track samples and energy counters at each simulated day's end."""

    apad_ids: tuple[int, ...]
    start_us: int
    max_rows: int = DEFAULT_MAX_TRACK_ROWS
    complete: bool = True  # False: the track starts at a restore, not at the mission's start
    day_energy: list[NDArray[np.float64]] = field(default_factory=list)  # per day end: (m, 3) counters, Wh
    _track: ThinnedSeries = field(init=False)  # t_s, then lat, lon, cost per aPad
    _k: int = field(init=False, default=0)  # samples offered

    def __post_init__(self) -> None:
        self._track = ThinnedSeries(1 + 3 * len(self.apad_ids), self.max_rows)

    def sample(self, t_s: float, lat: list[float], lon: list[float], cost_m: list[float]) -> None:
        self._track.offer(self._k, [t_s, *lat, *lon, *cost_m])
        self._k += 1

    def stretch(self, upto_k: int, t_s: Callable[[int], float],
                heard: Callable[[], tuple[list[float], list[float], list[float]]]) -> None:
        """The samples not yet offered up to index `upto_k`, all of the same position and cost (`heard`: the
        event platform, nothing heard changed meanwhile); only those the track keeps are made (the stride's
        multiples), and `heard` is asked only if there is one."""
        k, row = self._k, None
        while True:
            stride = self._track.stride  # it may double on the way
            k = -(-k // stride) * stride
            if k > upto_k:
                break
            lat, lon, cost_m = row = row or heard()
            self._track.offer(k, [t_s(k), *lat, *lon, *cost_m])
            k += 1
        self._k = max(self._k, upto_k + 1)

    def track(self) -> dict[str, NDArray[np.float64]]:
        """apad_t_s `(k,)` (mission seconds), apad_lat_deg, apad_lon_deg, apad_cost_m `(k, m)`."""
        a, m = self._track.array(), len(self.apad_ids)
        return {"apad_t_s": a[:, 0], "apad_lat_deg": a[:, 1: 1 + m], "apad_lon_deg": a[:, 1 + m: 1 + 2 * m],
                "apad_cost_m": a[:, 1 + 2 * m:]}

    def energy_per_day(self, end: NDArray[np.float64], days: int) -> NDArray[np.float64]:
        """Wh per day `(days, m, 3)` (ENERGY_KEYS), given the counters at the mission's end `(m, 3)`."""
        cumulative = [*self.day_energy[:days], end][:days]
        if not cumulative:
            return np.zeros((0, len(self.apad_ids), len(ENERGY_KEYS)))
        stacked = np.stack(cumulative)
        return np.diff(stacked, axis=0, prepend=np.zeros_like(stacked[:1]))


def energy_now(world: World, apad_ids: tuple[int, ...]) -> NDArray[np.float64]:
    """Each aPad's energy counters `(m, 3)`, Wh (NaN: not an embedded SITL aPad)."""
    out = np.full((len(apad_ids), len(ENERGY_KEYS)), np.nan)
    for c, sysid in enumerate(apad_ids):
        vehicle = world.vehicles.get(sysid)
        if vehicle is not None:
            out[c] = [getattr(vehicle.energy_counters, key) for key in ENERGY_KEYS]
    return out


def start(world: World, complete: bool = True) -> ApadRecord:
    """An `ApadRecord` of the world's aPads, sampled by tasks on its clock from now on."""
    clock, fleet = world.clock, world.fleet
    days = fleet.recorder.days
    ids = tuple(a.system_id for a in world.scenario.apads)
    origin_us = days.start_us if days is not None else clock.now_us
    record = ApadRecord(ids, origin_us, complete=complete)

    def heard() -> tuple[list[float], list[float], list[float]]:
        views = [world.link.vehicles.get(a) for a in ids]
        return ([np.nan if v is None or v.lat_deg is None else v.lat_deg for v in views],
                [np.nan if v is None or v.lon_deg is None else v.lon_deg for v in views],
                [0.0 if v is None else v.goto_cost_m for v in views])

    def sample(now_us: int) -> None:
        if fleet.end_us is not None and now_us > fleet.end_us:
            return
        record.sample((now_us - origin_us) / US_PER_S, *heard())

    period_us = seconds_to_us(TRACK_PERIOD_S)
    first_us = clock.now_us

    def stretch(now_us: int) -> None:  # event platform: the samples before now, of what was heard all along
        upto_us = now_us - 1 if fleet.end_us is None else min(now_us - 1, fleet.end_us)
        record.stretch((upto_us - first_us) // period_us, lambda k: (first_us + k * period_us - origin_us) / US_PER_S,
                       heard)

    def day_end(now_us: int) -> None:
        if fleet.end_us is None or now_us <= fleet.end_us:
            record.day_energy.append(energy_now(world, ids))

    if isinstance(clock, EventClock):
        clock.on_time(stretch)
    else:
        clock.scheduler.every(TRACK_PERIOD_S, sample, "apad-track", clock.now_us)
    if days is not None:
        passed = max(clock.now_us - origin_us, 0) // days.day_us
        # Started mid-mission (a restored console): the days gone by are not known, not zero.
        record.day_energy.extend(np.full((len(ids), len(ENERGY_KEYS)), np.nan) for _ in range(passed))
        clock.scheduler.every(days.day_us / US_PER_S, day_end, "apad-day", origin_us + (passed + 1) * days.day_us)
    return record
