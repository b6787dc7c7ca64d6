"""Recorded runs for the console and reports: the GCS .tlog plus events.jsonl, frame by frame.

A run folder (from `vil run`/`run_mission` or the live console's `--out`) holds `gcs.tlog`, in
which every message the GCS saw is stamped (aMussel statuses, aPad telemetry, the GCS's own
commands), and `events.jsonl` with the loop's phases. Replaying reads the .tlog, in time order,
through the live link's own readers (`gcs.link.telemetry`) into a `VehicleRegistry`, feeds the
events to the same `MissionView` the live console uses (it reads that registry), and keeps one
`Snapshot` per second of mission time, so seeking is an index lookup. A long run keeps one per
`sample_period_s` (at most about `MAX_FRAMES` of them: a week's run one per 31 s), and a run that
says which aMussels it had (result.json) is read as a stream, never held whole in memory.
"""

from __future__ import annotations

import bisect
import json
import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from gcs.link import telemetry
from gcs.link.registry import VehicleRegistry
from gcs.link.router import GCS_SYSTEM_ID
from gcs.records.events import Event
from gcs.records.run_folder import RunFolder
from gcs.scenario.reader import MISSIONS_DIR, Scenario, ScenarioError, load_scenario
from gcs.view.model import MissionView, area_outline
from gcs.view.snapshot import Snapshot
from mavlink_dialect import Codec, mavlink, tlog
from missiontime import us_to_s
from mussel_sim.placement import load_area

REPO_MISSIONS = MISSIONS_DIR
MAX_FRAMES = 20_000  # snapshots a replay keeps: one per second up to 5.5 h of mission, coarser beyond


def sample_period_s(span_s: float) -> float:
    """Seconds between a replay's snapshots for a run of `span_s`: 1, or a whole number of seconds
    that keeps them within `MAX_FRAMES`."""
    return float(max(1, math.ceil(span_s / MAX_FRAMES)))


class ReplayError(ValueError):
    pass


def read_tlog(path: Path) -> Iterator[tuple[int, Any]]:
    """(stamp_us, message) per record of a .tlog."""
    codec = Codec(GCS_SYSTEM_ID, 0)
    try:
        for stamp, frame in tlog.frames(path):
            for msg in codec.decode(frame):
                yield stamp, msg
    except tlog.TlogError as exc:
        raise ReplayError(str(exc)) from None


def read_events(path: Path) -> list[Event]:
    if not path.exists():
        return []
    out = []
    for k, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
        if line.strip():
            try:
                obj = json.loads(line)
                t_s, kind = float(obj.pop("t_s")), str(obj.pop("event"))
            except (ValueError, TypeError, KeyError, AttributeError) as exc:
                raise ReplayError(f"{path}:{k}: not an event ({type(exc).__name__}: {exc})") from None
            if not math.isfinite(t_s):
                raise ReplayError(f"{path}:{k}: t_s {t_s} is not a finite mission time")
            out.append(Event(t_s, kind, obj))
    return out


def _read_json(path: Path) -> dict[str, object]:
    """result.json or console.json of a run; {} if absent."""
    if not path.exists():
        return {}
    try:
        obj = json.loads(path.read_text(encoding="utf-8"))
    except (ValueError, OSError) as exc:
        raise ReplayError(f"{path}: not readable JSON: {exc}") from None
    if not isinstance(obj, dict):
        raise ReplayError(f"{path}: expected a JSON object")
    return obj


@dataclass
class RunFiles:
    """A recorded run: its folder, the .tlog to replay (the folder's, or one given), what it reported."""

    run: RunFolder
    tlog: Path
    result: dict[str, object]

    @property
    def folder(self) -> Path:
        return self.run.path

    @property
    def events(self) -> Path:
        return self.run.events


def run_files(path: str | Path) -> RunFiles:
    """The files of the run at `path`: a run folder (`runs/latest` too), a .tlog in one, or any other
    file of one (its result.json, say: the folder it is in)."""
    folder = RunFolder.at(path)
    if folder.path.is_file() and folder.path.suffix != ".tlog":  # result.json, events.jsonl ...: their run
        folder = RunFolder.at(folder.path.parent)
    if folder.path.is_dir():
        tlog = folder.gcs_tlog
        if not tlog.exists():
            raise ReplayError(f"{folder.path}: no {tlog.name} in this folder")
    elif folder.path.is_file():
        tlog, folder = folder.path, RunFolder.at(folder.path.parent)  # runs/latest/gcs.tlog: the run's own name
    else:
        raise ReplayError(f"{folder.path}: no such run folder or .tlog")
    result = {**_read_json(folder.console), **_read_json(folder.result)}
    return RunFiles(folder, tlog, result)


def find_scenario(files: RunFiles, explicit: str | Path | None = None) -> Scenario | None:
    """The run's scenario: given, named in console.json, or missions/NAME.toml by result.json's name."""
    if explicit is not None:
        return load_scenario(explicit)  # found as every command finds a scenario; a bad one is refused
    candidates: list[Path] = []
    if isinstance(files.result.get("scenario_path"), str):
        candidates.append(Path(str(files.result["scenario_path"])))
    name = files.result.get("scenario")
    if isinstance(name, str):
        candidates += [Path("missions") / f"{name}.toml", REPO_MISSIONS / f"{name}.toml"]
    for path in candidates:
        if path.exists():
            try:
                return load_scenario(path)
            except ScenarioError:
                pass
    return None


class Replay:
    """One snapshot per second of a recorded run."""

    def __init__(self, frames: list[Snapshot], source: str) -> None:
        if not frames:
            raise ReplayError(f"{source}: the log holds no mission time")
        self.frames = frames
        self.source = source
        self._times = [f.t_s for f in frames]
        self.end_s = frames[-1].t_s

    def at(self, t_s: float) -> Snapshot:
        k = bisect.bisect_right(self._times, t_s) - 1
        return self.frames[max(k, 0)]


def load_replay(path: str | Path, scenario: str | Path | None = None) -> Replay:
    files = run_files(path)
    found = find_scenario(files, scenario)
    told = _told_mussels(files.result)
    stream: Iterable[tuple[int, Any]]
    if found is not None and told is not None:  # what the replay needs up front is known: read as a stream
        stream, ids, apad_id = read_tlog(files.tlog), told, found.apad.system_id
        span_s = float(str(files.result.get("duration_s", found.mission.duration_s)))
        first = tlog.first_stamp_us(files.tlog)
        if first is None:
            raise ReplayError(f"{files.tlog}: empty log")
        t0_us = first
    else:  # an older or a console's folder: the log itself says who was there
        held = list(read_tlog(files.tlog))
        if not held:
            raise ReplayError(f"{files.tlog}: empty log")
        t0_us = held[0][0]
        apad_id, ids = _apad_and_mussels(held)
        span_s = us_to_s(held[-1][0] - t0_us)
        stream = held
    period_s = sample_period_s(span_s)
    registry = VehicleRegistry()
    if found is not None:
        try:
            outline = area_outline(load_area(found.fleet.area).geometry)
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise ReplayError(f"{found.fleet.area}: bad area: {exc}") from None
        model = MissionView(registry, found.apad.system_id, found.mission.pool_threshold,
                             found.mission.duration_s, str(files.folder), ids, outline,
                             apad_ids=[a.system_id for a in found.apads],
                             sinking_counts_active=found.mission.sinking_counts_active)
    else:
        model = MissionView(registry, apad_id, 0.8, span_s, str(files.folder), ids)
    events = read_events(files.events)
    frames: list[Snapshot] = []
    next_sample_s = 0.0
    e = 0

    def sample_until(t_s: float) -> None:
        nonlocal next_sample_s, e
        while next_sample_s <= t_s:
            while e < len(events) and events[e].t_s <= next_sample_s:
                model.event(events[e])
                e += 1
            model.sample(next_sample_s)
            frames.append(model.snapshot(next_sample_s))
            next_sample_s += period_s

    last_us = t0_us
    for stamp, msg in stream:
        last_us = stamp
        t_s = us_to_s(stamp - t0_us)
        if t_s >= next_sample_s:
            sample_until(t_s - 1e-9)
        record = telemetry.read(msg)  # what the live link read from the same message
        if record is not None and not isinstance(record, telemetry.Rejected | telemetry.CommandAck):
            registry.apply(msg.get_srcSystem(), record, stamp - t0_us)
    end_s = last_us - t0_us
    sample_until(us_to_s(end_s))
    for ev in events[e:]:
        model.event(ev)
    frames.append(model.snapshot(us_to_s(end_s)))
    return Replay(frames, str(files.folder))


def _told_mussels(result: dict[str, object]) -> np.ndarray | None:
    """The aMussel ids a run's result.json lists (sorted), None if it lists none."""
    mussels = result.get("mussels")
    if not isinstance(mussels, list) or not mussels:
        return None
    ids = [m["id"] for m in mussels if isinstance(m, dict) and type(m.get("id")) is int]
    return np.array(sorted(ids), np.int64) if len(ids) == len(mussels) else None


def _apad_and_mussels(stream: list[tuple[int, mavlink.MAVLink_message]]) -> tuple[int, np.ndarray]:
    apad_id = 1
    ids: set[int] = set()
    for _, msg in stream:
        if isinstance(msg, mavlink.MAVLink_amussel_status_message):
            ids.add(msg.mussel_id)
        elif isinstance(msg, mavlink.MAVLink_heartbeat_message) and msg.type == mavlink.MAV_TYPE_SURFACE_BOAT:
            apad_id = msg.get_srcSystem()
    return apad_id, np.array(sorted(ids), np.int64)
