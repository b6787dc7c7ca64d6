"""What a report reads from one recorded run, gathered once: the indices, per-second history,
each aMussel's figures, each aPad's track, the area, the origin of the metre axes, the events.

The history comes from the GCS log replayed through the console's model (`gcs.records.playback`),
sampled once per second of mission time; the indices and the per-aMussel facts from result.json
when the run wrote one (headless runs), else from the same replay. A run whose traces.npz holds
what a report draws is read from it instead, at a cost that does not grow with the mission
(`gcs.report.traces`; `gcs.report.load` chooses).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from gcs.records.events import Event
from gcs.records.playback import ReplayError, find_scenario, load_replay, read_events, run_files
from gcs.scenario.reader import Scenario
from gcs.view.snapshot import Snapshot
from mavlink_dialect import tlog
from mussel_sim.geo import flat_m
from mussel_sim.placement import load_area
from mussel_sim.vocabulary import MusselState

UNHEARD = 255  # in `RunData.state`: no report from this aMussel yet
# result.json's per-aPad shares of the mission time by what the aPad was doing (newer runs)
APAD_SHARES = ("travelling_share", "docking_share", "holding_share")


@dataclass(frozen=True)
class Indices:
    """The paper's Table II columns."""

    avg_uptime_pct: float
    max_uptime_pct: float
    min_uptime_pct: float
    cost_m: float
    active_avg: float
    source: str  # "result.json" or "replay"


@dataclass(frozen=True)
class Origin:
    """Where the metre axes start (east and north of it, on the local flat-earth plane)."""

    lat_deg: float
    lon_deg: float
    name: str  # "aPad 1 home", "area centre"

    def text(self) -> str:
        ns, ew = ("N" if self.lat_deg >= 0 else "S"), ("E" if self.lon_deg >= 0 else "W")
        return f"{self.name}, {abs(self.lat_deg):.6f}° {ns} {abs(self.lon_deg):.6f}° {ew}"

    def xy(self, lat_deg: NDArray[np.float64], lon_deg: NDArray[np.float64]) -> tuple[NDArray[np.float64],
                                                                                     NDArray[np.float64]]:
        return flat_m(lat_deg, lon_deg, self.lat_deg, self.lon_deg)


@dataclass(frozen=True)
class ApadTrack:
    """One aPad's position once per second of mission time (only the seconds it was heard)."""

    system_id: int
    t_s: NDArray[np.float64]
    lat_deg: NDArray[np.float64]
    lon_deg: NDArray[np.float64]
    cost_m: NDArray[np.float64]  # (k,) its movement cost so far, at every sample of `RunData.t_s`


@dataclass(frozen=True)
class MusselFacts:
    id: int
    start_battery: float  # fraction of the 3.6-4.2 V range; NaN never heard
    end_battery: float
    uptime_pct: float
    dockings: int
    depleted_s: float  # mission seconds spent DEPLETED
    first_depleted_s: float | None  # the mission second it first ran flat; None: never
    state_s: dict[str, float]  # mission seconds per state (lower-case state name)
    end_state: str
    apad: int  # the aPad whose share it ended in (0: none known)
    start_lat_deg: float  # where it was first heard (its deployment position)
    start_lon_deg: float
    end_lat_deg: float
    end_lon_deg: float

    @property
    def never_collected(self) -> bool:
        return self.dockings == 0

    @property
    def depleted(self) -> bool:
        return self.depleted_s > 0


@dataclass(frozen=True)
class RunData:
    folder: Path
    title: str
    strategy: str  # as the run used it: "cautious", or "cautious, then weighted" after the operator's switch
    result: dict[str, object]
    indices: Indices
    scenario: Scenario | None
    start_us: int  # the log's clock at mission time 0 (a fixed nominal date for lockstep runs)
    duration_s: float
    end_s: float
    end_reason: str
    pool_threshold: float
    t_s: NDArray[np.float64]  # (k,) sample times, one per mission second
    active: NDArray[np.int32]  # (k,)
    battery: NDArray[np.float32]  # (k, n) fraction, NaN before first heard
    state: NDArray[np.uint8]  # (k, n) MusselState, UNHEARD before first heard
    cost_m: NDArray[np.float64]  # (k,) every aPad's movement cost so far, summed
    ids: NDArray[np.int64]  # (n,)
    mussels: tuple[MusselFacts, ...]
    tracks: tuple[ApadTrack, ...]
    outline_lat_deg: NDArray[np.float64]  # NaN between rings
    outline_lon_deg: NDArray[np.float64]
    area: Any  # the scenario's area (a shapely Polygon or MultiPolygon, lon/lat); None without a scenario
    origin: Origin
    events: tuple[Event, ...]

    @property
    def name(self) -> str:
        """The run folder's own name (`latest` followed to the folder it names)."""
        return self.folder.resolve().name

    @property
    def swarm(self) -> bool:
        return len(self.tracks) > 1


def load_replayed_run(run: str | Path, scenario: str | Path | None = None) -> RunData:
    """Everything a report shows of one run, from its GCS log replayed (every run folder has one; its
    cost grows with the mission: `gcs.report.load` reads traces.npz instead where it can);
    `ReplayError` / `ScenarioError` on bad input."""
    files = run_files(run)
    check_result(files.result, files.run.result)
    found = find_scenario(files, scenario)
    frames = load_replay(run, scenario).frames
    last = frames[-1]
    k = last.hist_t_s.size
    sampled = frames[:k]  # one frame per sample time, the same rows as the history arrays
    battery = last.hist_battery
    state = np.stack([f.state for f in sampled]) if k else np.zeros((0, last.mussel_ids.size), np.uint8)
    state = np.where(np.isnan(battery), UNHEARD, state).astype(np.uint8)
    tracks = tuple(_track(sampled, column) for column in range(len(last.apads)))
    events = tuple(read_events(files.events))
    strategy = strategies_used(files.result, events)
    outline = last.outline_lat_deg, last.outline_lon_deg
    return RunData(
        folder=files.folder,
        title=run_title(files.result, strategy, files.folder),
        strategy=strategy,
        result=files.result,
        indices=indices(files.result, last),
        scenario=found,
        start_us=next(iter(tlog.frames(files.tlog)))[0],
        duration_s=last.duration_s,
        end_s=last.t_s,
        end_reason=str(files.result.get("end_reason") or last.ended or "-"),
        pool_threshold=last.pool_threshold,
        t_s=last.hist_t_s,
        active=last.hist_active,
        battery=battery,
        state=state,
        cost_m=np.sum([t.cost_m for t in tracks], axis=0) if tracks else np.zeros(k),
        ids=last.mussel_ids,
        mussels=_mussels(frames, state, files.result, events),
        tracks=tracks,
        outline_lat_deg=outline[0],
        outline_lon_deg=outline[1],
        area=load_area(found.fleet.area).geometry if found is not None else None,  # the replay read it already
        origin=origin_of(found, tracks, outline),
        events=events,
    )


def check_result(result: dict[str, object], path: Path) -> None:
    """The fields of result.json a report reads have the types it reads them as (or are absent);
    `ReplayError` naming the first that has not."""
    def numbers(where: str, obj: object, keys: tuple[str, ...]) -> None:
        if not isinstance(obj, dict):
            raise ReplayError(f"{path}: {where.rstrip('.')} is {obj!r}, not a record")
        for key in keys:
            value = obj.get(key, 0.0)
            if not isinstance(value, int | float) or isinstance(value, bool):
                raise ReplayError(f"{path}: {where}{key} is {value!r}, not a number")

    if "uptime" in result:
        numbers("uptime.", result["uptime"], ("avg", "max", "min"))
    numbers("", result, ("cost_m", "active_avg"))
    for k, m in enumerate(as_list(result.get("mussels"))):
        if not isinstance(m, dict) or type(m.get("id")) is not int or not isinstance(m.get("dockings", []), list):
            raise ReplayError(f"{path}: mussels[{k}] is not an aMussel record (an int id, a list of dockings)")
        numbers(f"mussels[{k}].", m, ("start_battery", "uptime_pct"))
    for k, a in enumerate(as_list(result.get("apads"))):
        numbers(f"apads[{k}].", a, ("cost_m", "travelled_m", "idle_share", *APAD_SHARES))
        phases = a.get("phase_s", {})
        numbers(f"apads[{k}].phase_s.", phases, tuple(phases) if isinstance(phases, dict) else ())


def indices(result: dict[str, object], last: Snapshot) -> Indices:
    up = result.get("uptime")
    if isinstance(up, dict) and "cost_m" in result and "active_avg" in result:
        return Indices(float(up["avg"]), float(up["max"]), float(up["min"]), float(str(result["cost_m"])),
                       float(str(result["active_avg"])), "result.json")
    u = last.uptime_pct
    cost = sum(a.cost_m for a in last.apads)
    return Indices(float(u.mean()), float(u.max()), float(u.min()), cost,
                   float(last.hist_active.mean()) if last.hist_active.size else 0.0, "replay")


def run_title(result: dict[str, object], strategy: str, folder: Path) -> str:
    if "scenario" in result and "strategy" in result:
        return f"{result['scenario']} {strategy} seed {result.get('seed', '?')}"
    return folder.resolve().name  # `runs/latest` is the folder it points at


def strategies_used(result: dict[str, object], events: tuple[Event, ...]) -> str:
    """The collection strategy the run started with and each one the operator switched to, in order
    ("cautious, then weighted"); result.json's when the events do not say; "-" when neither does."""
    used: list[str] = []
    for ev in events:
        name = ev.fields.get("strategy" if ev.kind == "mission_start" else "new")
        if ev.kind in ("mission_start", "strategy_switch") and isinstance(name, str) and name not in used[-1:]:
            used.append(name)
    if not used:
        return str(result.get("strategy", "-"))
    return ", then ".join(used)


def _track(frames: list[Snapshot], column: int) -> ApadTrack:
    t = np.array([f.t_s for f in frames], np.float64)
    pads = [f.apads[column] for f in frames]
    lat = np.array([np.nan if a.lat_deg is None else a.lat_deg for a in pads], np.float64)
    lon = np.array([np.nan if a.lon_deg is None else a.lon_deg for a in pads], np.float64)
    cost = np.array([a.cost_m for a in pads], np.float64)
    ok = np.isfinite(lat) & np.isfinite(lon)
    sysid = frames[-1].apads[column].system_id if frames else column + 1
    return ApadTrack(sysid, t[ok], lat[ok], lon[ok], cost)


def origin_of(found: Scenario | None, tracks: tuple[ApadTrack, ...],
            outline: tuple[NDArray[np.float64], NDArray[np.float64]]) -> Origin:
    """The first aPad's home (the scenario's), else where it was first heard, else the area's centre."""
    if found is not None:
        home = found.apads[0]
        return Origin(home.home_lat_deg, home.home_lon_deg, f"aPad {home.system_id} home")
    heard = [t for t in tracks if t.t_s.size]
    if heard:
        return Origin(float(heard[0].lat_deg[0]), float(heard[0].lon_deg[0]), f"aPad {heard[0].system_id} start")
    if outline[0].size:
        return Origin(float(np.nanmean(outline[0])), float(np.nanmean(outline[1])), "area centre")
    return Origin(0.0, 0.0, "0° N 0° E")


def _first_positions(frames: list[Snapshot]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Where each aMussel was first heard (its deployment position)."""
    n = frames[-1].mussel_ids.size
    lat, lon = np.full(n, np.nan), np.full(n, np.nan)
    for f in frames:
        m = f.mussel_ids.size
        fill = np.isnan(lat[:m]) & np.isfinite(f.lat_deg)
        lat[:m][fill], lon[:m][fill] = f.lat_deg[fill], f.lon_deg[fill]
        if not np.isnan(lat).any():
            break
    return lat, lon


def _mussels(frames: list[Snapshot], state: NDArray[np.uint8], result: dict[str, object],
             events: tuple[Event, ...]) -> tuple[MusselFacts, ...]:
    last = frames[-1]
    t_s = last.hist_t_s
    from_result = {m["id"]: m for m in as_list(result.get("mussels"))}  # checked: dicts with int ids
    docked_events: dict[int, int] = {}
    for ev in events:
        if ev.kind == "docked" and type(ev.fields.get("mussel")) is int:
            docked_events[ev.fields["mussel"]] = docked_events.get(ev.fields["mussel"], 0) + 1
    start_lat, start_lon = _first_positions(frames)
    battery = last.hist_battery
    owner = last.owner if last.owner.size == last.mussel_ids.size and last.owner.any() else None
    single = last.apads[0].system_id if len(last.apads) == 1 else 0
    out = []
    for c, mussel in enumerate(int(m) for m in last.mussel_ids):
        rec = from_result.get(mussel, {})
        heard = battery[:, c][np.isfinite(battery[:, c])]
        state_s = state_seconds(rec) or {s.name.lower(): float(np.count_nonzero(state[:, c] == s))
                                          for s in MusselState}
        dockings = as_list(rec.get("dockings"))
        out.append(MusselFacts(
            id=mussel,
            start_battery=float(rec.get("start_battery", heard[0] if heard.size else np.nan)),
            end_battery=float(heard[-1]) if heard.size else float("nan"),
            uptime_pct=float(rec.get("uptime_pct", last.uptime_pct[c])),
            # The loop's list misses the operator's manual docks; the 1 Hz states would miss one shorter
            # than a sample: each is a lower bound, so the larger holds.
            dockings=max(len(dockings) if "dockings" in rec else docked_events.get(mussel, 0),
                         entries_into_docked(state[:, c])),
            depleted_s=state_s.get(MusselState.DEPLETED.name.lower(), 0.0),
            first_depleted_s=first_depleted(rec, t_s, state[:, c]),
            state_s=state_s,
            end_state=MusselState(int(last.state[c])).name.lower() if heard.size else "never heard",
            apad=int(owner[c]) if owner is not None else single,
            start_lat_deg=float(start_lat[c]), start_lon_deg=float(start_lon[c]),
            end_lat_deg=float(last.lat_deg[c]), end_lon_deg=float(last.lon_deg[c]),
        ))
    return tuple(out)


def entries_into_docked(state: NDArray[np.uint8]) -> int:
    """How many times the sampled states enter DOCKED (a docking the telemetry saw)."""
    docked = state == MusselState.DOCKED
    return int(np.count_nonzero(docked[1:] & ~docked[:-1]) + (1 if docked.size and docked[0] else 0))


def first_depleted(rec: dict[str, Any], t_s: NDArray[np.float64], state: NDArray[np.uint8]) -> float | None:
    """result.json's `first_depleted_s` when the run wrote it (exact), else the first 1 Hz sample DEPLETED."""
    if "first_depleted_s" in rec:
        given = rec["first_depleted_s"]
        return float(given) if isinstance(given, int | float) else None
    flat = np.flatnonzero(state == MusselState.DEPLETED)
    return float(t_s[flat[0]]) if flat.size else None


def state_seconds(rec: dict[str, Any]) -> dict[str, float] | None:
    """Seconds per state as result.json gives them, when the run wrote them (exact, not 1 Hz samples)."""
    given = rec.get("state_s")
    if not isinstance(given, dict):
        return None
    names = {s.name.lower() for s in MusselState}
    out = {str(k).lower(): float(v) for k, v in given.items() if isinstance(v, int | float)}
    return out if out and set(out) <= names else None


def as_list(value: object) -> list[Any]:
    return value if isinstance(value, list) else []
