"""A report's data from what a headless run wrote for it (traces.npz format 2, result.json, events.jsonl),
without replaying its GCS log: a report's cost no longer grows with the mission.

Replaying the log decodes every message the GCS saw (about 80,000 an hour for pool12) and keeps a
sample per mission second: 3.4 s and 200 MB for a 1-h run, 14.6 s and 1 GB for 9.5 h, a week out of
reach. traces.npz holds what the report draws at a bounded number of points (the recorder's battery
and state traces and each aPad's track, at most 8,192 samples each whatever the duration), so the
report reads a few MB. The time axis of the report's history is the traces' (evenly spaced steps);
the active count and the aPads' movement cost are taken at those instants. Runs without it (older
ones, consoles restored from a checkpoint: `track_complete` False) are replayed as before.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from gcs.records.events import Event
from gcs.records.playback import ReplayError, RunFiles, read_events
from gcs.report.run_data import (
    ApadTrack,
    Indices,
    MusselFacts,
    RunData,
    as_list,
    entries_into_docked,
    first_depleted,
    origin_of,
    run_title,
    state_seconds,
    strategies_used,
)
from gcs.scenario.reader import Scenario
from gcs.view.model import area_outline
from mavlink_dialect import tlog
from missiontime import US_PER_S
from mussel_sim.placement import load_area
from mussel_sim.vocabulary import MusselState

TRACES_FORMAT = 2  # the oldest traces.npz a report reads (the writer: gcs.mission.outcome.TRACES_FORMAT)


def read_traces(path: Path) -> dict[str, NDArray[Any]] | None:
    """The arrays of a traces.npz a report can be drawn from; None if there is none or it is older
    or from a restored console (its track starts at the restore)."""
    if not path.exists():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except (OSError, ValueError) as exc:
        raise ReplayError(f"{path}: not a readable traces file: {exc}") from None
    if int(arrays.get("traces_format", 0)) < TRACES_FORMAT or not bool(arrays.get("track_complete", False)):
        return None
    return arrays


def history(z: dict[str, NDArray[Any]]) -> dict[str, NDArray[Any]]:
    """The report's history at the traces' steps: t_s `(k,)` (mission s since the start), active `(k,)`,
    battery `(k, n)`, state `(k, n)`, apad_cost_m `(k, m)`, and the aPads' own track times."""
    step_us = np.asarray(z["step_time_us"], np.int64)
    origin_us = int(z["start_us"]) if "start_us" in z else _first_step_origin_us(step_us)
    steps = np.asarray(z["battery_steps"], np.int64)
    t_s = (step_us[steps] - origin_us) / US_PER_S
    track_t = np.asarray(z["apad_t_s"], np.float64)
    cost = np.asarray(z["apad_cost_m"], np.float64)
    cost_at = np.stack([np.interp(t_s, track_t, cost[:, c]) if track_t.size else np.zeros(t_s.size)
                        for c in range(cost.shape[1])], axis=1) if cost.ndim == 2 else np.zeros((t_s.size, 0))
    return {"t_s": t_s, "active": np.asarray(z["active_count"], np.int32)[steps],
            "battery": np.asarray(z["battery"], np.float32), "state": np.asarray(z["battery_state"], np.uint8),
            "apad_cost_m": cost_at, "end_s": np.array((step_us[-1] - origin_us) / US_PER_S if step_us.size else 0.0)}


def _first_step_origin_us(step_us: NDArray[np.int64]) -> int:
    """The mission's start in traces written before they kept it: a first step as long as the second."""
    return int(step_us[0] - (step_us[1] - step_us[0])) if step_us.size > 1 else 0


def owners(events: tuple[Event, ...], ids: NDArray[np.int64], single: int) -> NDArray[np.int64]:
    """The aPad whose share each aMussel ended in: the last re-share's, else the one aPad (0: none known)."""
    owner = np.full(ids.size, single, np.int64)
    for ev in events:
        shares = ev.fields.get("shares")
        if ev.kind == "reshare" and isinstance(shares, dict):
            by_id = {m: int(a) for a, ms in shares.items() if str(a).isdigit() and isinstance(ms, list)
                     for m in ms if type(m) is int}
            owner = np.array([by_id.get(int(m), 0) for m in ids], np.int64)
    return owner


def outline_of(found: Scenario | None) -> tuple[NDArray[np.float64], NDArray[np.float64], Any]:
    """The scenario's area as an outline (lat, lon; NaN between rings) and its geometry; empty and None without one."""
    if found is None:
        return np.zeros(0), np.zeros(0), None
    try:
        geometry = load_area(found.fleet.area).geometry
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ReplayError(f"{found.fleet.area}: bad area: {exc}") from None
    lat, lon = area_outline(geometry)
    return lat, lon, geometry


def end_state_name(code: int) -> str:
    return MusselState(int(code)).name.lower()


def start_stamp_us(files: RunFiles) -> int:
    """The log's clock at mission time 0 (its first record; 0 without one), from its first 8 bytes."""
    try:
        return tlog.first_stamp_us(files.tlog) or 0
    except OSError:
        return 0


def traced_run(files: RunFiles, found: Scenario | None, z: dict[str, NDArray[Any]]) -> RunData:
    """Everything a report shows of one run, from its traces.npz (`read_traces`), result.json and events."""
    result = files.result
    events = tuple(read_events(files.events))
    strategy = strategies_used(result, events)
    h = history(z)
    ids = np.asarray(z["ids"], np.int64)
    apad_ids = [int(a) for a in z["track_apad_ids"]]
    track_t = np.asarray(z["apad_t_s"], np.float64)
    tracks = []
    for c, sysid in enumerate(apad_ids):
        lat, lon = z["apad_lat_deg"][:, c], z["apad_lon_deg"][:, c]
        ok = np.isfinite(lat) & np.isfinite(lon)
        tracks.append(ApadTrack(sysid, track_t[ok], lat[ok], lon[ok], h["apad_cost_m"][:, c]))
    outline_lat, outline_lon, area = outline_of(found)
    owner = owners(events, ids, apad_ids[0] if len(apad_ids) == 1 else 0)
    end_s = float(h["end_s"])
    return RunData(
        folder=files.folder,
        title=run_title(result, strategy, files.folder),
        strategy=strategy,
        result=result,
        indices=_indices(result, z),
        scenario=found,
        start_us=start_stamp_us(files),
        duration_s=float(str(result.get("duration_s", end_s))),
        end_s=end_s,
        end_reason=str(result.get("end_reason") or "-"),
        pool_threshold=found.mission.pool_threshold if found is not None else 0.8,
        t_s=h["t_s"],
        active=h["active"],
        battery=h["battery"],
        state=h["state"],
        cost_m=h["apad_cost_m"].sum(axis=1),
        ids=ids,
        mussels=_mussels(z, h, result, events, owner),
        tracks=tuple(tracks),
        outline_lat_deg=outline_lat,
        outline_lon_deg=outline_lon,
        area=area,
        origin=origin_of(found, tuple(tracks), (outline_lat, outline_lon)),
        events=events,
    )


def _indices(result: dict[str, object], z: dict[str, NDArray[Any]]) -> Indices:
    """result.json's Table II indices (a headless run writes them); else from the traces' counts."""
    up = result.get("uptime")
    if isinstance(up, dict) and "cost_m" in result and "active_avg" in result:
        return Indices(float(up["avg"]), float(up["max"]), float(up["min"]), float(str(result["cost_m"])),
                       float(str(result["active_avg"])), "result.json")
    names = [str(n) for n in z["state_names"]]
    seconds = np.asarray(z["state_s"], np.float64)
    total = seconds.sum(axis=1)
    u = np.divide(100.0 * seconds[:, names.index("active")], total, out=np.zeros(total.size), where=total > 0)
    active = np.asarray(z["active_count"], np.float64)
    return Indices(float(u.mean()), float(u.max()), float(u.min()), float(z["apad_cost_m"][-1].sum())
                   if z["apad_cost_m"].size else 0.0, float(active.mean()) if active.size else 0.0, "traces.npz")


def _mussels(z: dict[str, NDArray[Any]], h: dict[str, NDArray[Any]], result: dict[str, object],
             events: tuple[Event, ...], owner: NDArray[np.int64]) -> tuple[MusselFacts, ...]:
    from_result = {m["id"]: m for m in as_list(result.get("mussels"))}  # checked: dicts with int ids
    docked_events: dict[int, int] = {}
    for ev in events:
        if ev.kind == "docked" and type(ev.fields.get("mussel")) is int:
            docked_events[ev.fields["mussel"]] = docked_events.get(ev.fields["mussel"], 0) + 1
    names = [str(n) for n in z["state_names"]]
    seconds = np.asarray(z["state_s"], np.float64)
    state, battery, t_s = h["state"], h["battery"], h["t_s"]
    out = []
    for c, mussel in enumerate(int(m) for m in z["ids"]):
        rec = from_result.get(mussel, {})
        state_s = state_seconds(rec) or {name: float(seconds[c, k]) for k, name in enumerate(names)}
        total = sum(state_s.values())
        dockings = as_list(rec.get("dockings"))
        out.append(MusselFacts(
            id=mussel,
            start_battery=float(rec.get("start_battery", battery[0, c] if battery.shape[0] else np.nan)),
            end_battery=float(z["end_battery"][c]),
            uptime_pct=float(rec.get("uptime_pct", 100.0 * state_s.get("active", 0.0) / total if total else 0.0)),
            dockings=max(len(dockings) if "dockings" in rec else docked_events.get(mussel, 0),
                         entries_into_docked(state[:, c])),
            depleted_s=state_s.get(MusselState.DEPLETED.name.lower(), 0.0),
            first_depleted_s=first_depleted(rec, t_s, state[:, c]),
            state_s=state_s,
            end_state=end_state_name(int(z["end_state"][c])),
            apad=int(owner[c]),
            start_lat_deg=float(z["start_lat_deg"][c]), start_lon_deg=float(z["start_lon_deg"][c]),
            end_lat_deg=float(z["end_lat_deg"][c]), end_lon_deg=float(z["end_lon_deg"][c]),
        ))
    return tuple(out)
