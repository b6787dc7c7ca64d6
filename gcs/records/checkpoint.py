"""Crash-safe checkpoints of a running mission, so a killed GCS continues the same mission.

A checkpoint holds what cannot be heard again from the vehicles: mission time, the simulated
fleet (state arrays, its rng, the uptime recorder), the scenario loop's status (phase, strategy,
cost, cycles), and what the GCS knew (aMussel and aPad views). In lockstep the SITL aPad runs
in this process, so its state (hull, primitive, latches, mode) is saved too; in the field the aPad
is its own vehicle and keeps its own state across a GCS crash, so `vehicle` is None.

A save costs the same at any mission time. What grows with the mission (the recorder's rows: active
count and time per step, battery trace rows) is appended to two side files, `checkpoint.steps` and
`checkpoint.traces` (a 16-byte header, then fixed-size little-endian records), and never rewritten.
Everything else, the recorder's fixed-size head included, is the small file `checkpoint.pkl`, written
atomically (temp file, then `os.replace`) after the rows: it says how many records of each side file
are valid and their CRC-32. A kill -9 at any instant leaves either the previous small file or the new
one, and side files at least as long as it says; records past that are ignored on load and cut off
when the resumed run saves. Trace rows the recorder later decimates stay in the file and are
filtered out on load by the saved stride (`Recorder.restore`), so the file stays append-only and
bounded by the recorder's budget times (1 + decimations / 2). No fsync: the kernel keeps the data of
a killed process; an fsync per checkpoint cost more than the mission (power loss is not covered).
Pickle is fine here: the files are our own, written and read by the same version (checked), in the
run's folder; a missing, short or garbled side file is a `CheckpointError`.

The run's logs go on past the last checkpoint until the crash; the resumed run simulates that
stretch again, so `cut_logs` first cuts them back to the checkpoint (events.jsonl to its length
then, each .tlog and aPad event log before its mission time): every event and message is in the logs once.

A resume (`vil run --resume` in lockstep, `vil gcs --resume` on the console's clock): `files.read()`,
`cut_logs`, a world built with `mission_start_us=0`, its clock starting at `ckpt.time_us` and
`append_logs=True` (the console keeps its log epoch in `console.json`), `restore(world, ckpt)`,
`loop.status = ckpt.loop_status`, `loop.run(resume=True)`, saving with the same `files` (they know
where the side files' valid rows end), `files.remove()` once the mission ended. A wall clock runs on
while the world is built, hence `RESTORE_SLACK_US`.
"""

from __future__ import annotations

import os
import pickle
import struct
import zlib
from collections.abc import Callable, Iterable
from dataclasses import dataclass, fields
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

import numpy as np

from apad_sitl import logs as apad_logs
from apad_sitl.primitives import PrimitiveState
from apad_sitl.vehicle import VehicleState
from gcs.link.registry import VehicleRegistry
from gcs.mission.control import LoopStatus
from gcs.records.events import EVENTS_NAME
from mavlink_dialect import mavlink, tlog
from mussel_sim.fleet_state import FleetState
from mussel_sim.recorder import Recorder, RecorderHead, RecorderRows

if TYPE_CHECKING:
    from gcs.mission.loop import EnergySharingLoop
    from gcs.mission.scenario import Scenario
    from gcs.mission.world import World

CHECKPOINT_NAME = "checkpoint.pkl"
CHECKPOINT_PERIOD_S = 10.0  # mission time between checkpoints
FORMAT_VERSION = 3
RESTORE_SLACK_US = 30_000_000  # a wall clock started at the checkpoint's time runs on while the world is built
STEPS_SUFFIX = ".steps"  # side files beside CHECKPOINT_NAME
TRACES_SUFFIX = ".traces"


class CheckpointError(Exception):
    """No usable checkpoint; the message is one line for the user."""


@dataclass(frozen=True)
class VehicleSnapshot:
    """The embedded SITL aPad (lockstep only)."""

    state: VehicleState
    primitive: PrimitiveState
    mode: int
    armed: bool
    speed_override_mps: float


@dataclass(frozen=True)
class Checkpoint:
    version: int
    run_key: tuple[str, str, int]  # scenario, collection strategy, seed: a checkpoint resumes only its own run
    time_us: int  # mission time
    fleet_state: FleetState
    fleet_rng_state: dict[str, Any]
    recorder: Recorder  # the live one at capture (not copied: save at once); rebuilt by load
    loop_status: LoopStatus
    registry: VehicleRegistry  # what the GCS had heard: the aPads' views and the aMussel table
    vehicle: VehicleSnapshot | None
    events_bytes: int = 0  # how long events.jsonl was


def scenario_key(s: Scenario) -> tuple[str, str, int]:
    """The run a scenario makes: a checkpoint resumes only its own."""
    return (s.name, s.mission.collect_strategy, s.seed)


def run_key(world: World) -> tuple[str, str, int]:
    return scenario_key(world.scenario)


def capture(world: World, loop: EnergySharingLoop) -> Checkpoint:
    v = world.vehicle
    snapshot = None
    if v is not None:
        snapshot = VehicleSnapshot(v.state, v.primitive, v.mode, v.armed, v._speed_override_mps)
    fleet = world.fleet
    # The registry and the loop status go in live, not copied: `save` pickles a capture at once.
    return Checkpoint(
        FORMAT_VERSION, run_key(world), world.clock.now_us, fleet.state, dict(fleet.rng.bit_generator.state),
        fleet.recorder, loop.status, world.link.registry, snapshot, world.events.bytes,
    )


def save(files: CheckpointFiles, ckpt: Checkpoint) -> None:
    """Append the recorder's new rows to the side files, then write the rest of `ckpt` atomically."""
    files.write(ckpt)


def load(files: CheckpointFiles | Path) -> Checkpoint:
    """Read a checkpoint (given its files, or the path of its small file); `CheckpointError` if unusable."""
    return (files if isinstance(files, CheckpointFiles) else CheckpointFiles(files)).read()


# --- files ------------------------------------------------------------------------------------------

_HEADER = struct.Struct("<8sII")  # magic, record size in bytes, 0
_STEPS_MAGIC, _TRACES_MAGIC = b"VILSTEPS", b"VILTRACE"
_STEP = np.dtype([("time_us", "<i8"), ("active", "<i4")])
_CHUNK_BYTES = 1 << 22  # side files are read this much at a time


def _trace_dtype(n_trace: int) -> np.dtype[Any]:
    return np.dtype([("step", "<i8"), ("u", "<f4", (n_trace,))])


@dataclass(frozen=True)
class _Valid:
    """How much of a side file a small file vouches for: the first `count` records, their CRC-32."""

    count: int
    crc: int


@dataclass(frozen=True)
class _Small:
    """What `checkpoint.pkl` holds: the checkpoint but its recorder, the recorder's head, the side files' extent."""

    version: int
    fields: dict[str, Any]
    recorder: RecorderHead
    steps: _Valid
    traces: _Valid


class _Appender:
    """One side file open for appending records, with the count and running CRC-32 of what it holds."""

    def __init__(self, path: Path, magic: bytes, dtype: np.dtype[Any], valid: _Valid | None) -> None:
        self.dtype, self.count, self.crc = dtype, 0, 0
        if valid is None:  # a new run: a new file
            self.file: IO[bytes] = path.open("wb")
            self.file.write(_HEADER.pack(magic, dtype.itemsize, 0))
        else:  # a resumed run: keep the valid records, cut off what a crash left after them
            self.file = path.open("r+b")
            self.file.truncate(_HEADER.size + valid.count * dtype.itemsize)
            self.file.seek(0, os.SEEK_END)
            self.count, self.crc = valid.count, valid.crc

    def append(self, records: np.ndarray) -> None:
        data = records.astype(self.dtype, copy=False).tobytes()
        self.file.write(data)
        self.crc = zlib.crc32(data, self.crc)
        self.count += records.size

    def valid(self) -> _Valid:
        self.file.flush()  # into the kernel before the small file that vouches for it
        return _Valid(self.count, self.crc)


def _read_records(path: Path, magic: bytes, dtype: np.dtype[Any], valid: _Valid,
                  keep: Callable[[np.ndarray], np.ndarray] | None = None) -> np.ndarray:
    """The first `valid.count` records of a side file (those `keep(chunk)` selects), checked against the CRC."""
    what = f"checkpoint side file {path}"
    try:
        with path.open("rb") as f:
            head = f.read(_HEADER.size)
            if len(head) < _HEADER.size or _HEADER.unpack(head)[:2] != (magic, dtype.itemsize):
                raise CheckpointError(f"{what} is not of this checkpoint (bad header)")
            if os.fstat(f.fileno()).st_size < _HEADER.size + valid.count * dtype.itemsize:
                raise CheckpointError(f"{what} is truncated: fewer than the {valid.count} records saved")
            per_chunk = max(1, _CHUNK_BYTES // max(dtype.itemsize, 1))
            parts, crc, left = [], 0, valid.count
            while left:
                data = f.read(min(left, per_chunk) * dtype.itemsize)
                crc = zlib.crc32(data, crc)
                chunk = np.frombuffer(data, dtype)
                parts.append(chunk if keep is None else chunk[keep(chunk)].copy())
                left -= chunk.size
    except FileNotFoundError:
        raise CheckpointError(f"{what} is missing") from None
    except OSError as exc:
        raise CheckpointError(f"cannot read {what}: {exc}") from None
    if crc != valid.crc:
        raise CheckpointError(f"{what} is corrupt (CRC mismatch)")
    return np.concatenate(parts) if parts else np.zeros(0, dtype)


class CheckpointFiles:
    """The checkpoint of one run: the small file at `path` and its two append-only side files.

    `write` appends the rows recorded since the previous `write` (or since the checkpoint `read`,
    which a resumed run must call first), so keep one instance for the whole run.
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        self.steps_path = path.with_suffix(STEPS_SUFFIX)
        self.traces_path = path.with_suffix(TRACES_SUFFIX)
        self._tmp = path.with_name(path.name + ".tmp")
        self._resume: tuple[_Valid, _Valid, int] | None = None  # what `read` found
        self._steps: _Appender | None = None
        self._traces: _Appender | None = None
        self._written = 0  # recorder steps in the side files

    def read(self) -> Checkpoint:
        try:
            with self.path.open("rb") as f:
                small = pickle.load(f)
        except FileNotFoundError:
            raise CheckpointError(f"no checkpoint to resume from: {self.path} does not exist") from None
        except Exception as exc:  # a short or garbled pickle raises almost anything
            raise CheckpointError(f"cannot read checkpoint {self.path}: {_one_line(exc)}") from None
        if not isinstance(small, _Small) or small.version != FORMAT_VERSION:
            raise CheckpointError(f"{self.path} is not a checkpoint of this version of vil")
        head = small.recorder
        n_trace = head.ids.size if head.trace_ids is None else head.trace_ids.size
        steps = _read_records(self.steps_path, _STEPS_MAGIC, _STEP, small.steps)
        stride = head.trace_stride
        traces = _read_records(self.traces_path, _TRACES_MAGIC, _trace_dtype(n_trace), small.traces,
                               (lambda c: c["step"] % stride == 0) if stride > 0 else None)
        rows = RecorderRows(steps["time_us"].astype(np.int64), steps["active"].astype(np.int32),
                            traces["step"].astype(np.int64), traces["u"].astype(np.float32))
        try:
            recorder = Recorder.restore(head, rows)
            ckpt = Checkpoint(**small.fields, recorder=recorder)
        except (ValueError, TypeError) as exc:
            raise CheckpointError(f"checkpoint {self.path} does not hold together: {_one_line(exc)}") from None
        self._resume = (small.steps, small.traces, head.n_steps)
        return ckpt

    def write(self, ckpt: Checkpoint) -> None:
        rec = ckpt.recorder
        if self._steps is None or self._traces is None:
            self._open(rec.trace_ids.size)
        assert self._steps is not None and self._traces is not None
        head = rec.head()
        new = rec.rows_since(self._written)
        steps = np.empty(new.time_us.size, _STEP)
        steps["time_us"], steps["active"] = new.time_us, new.active_count
        self._steps.append(steps)
        traces = np.empty(new.trace_steps.size, self._traces.dtype)
        traces["step"], traces["u"] = new.trace_steps, new.trace
        self._traces.append(traces)
        rest = {f.name: getattr(ckpt, f.name) for f in fields(ckpt) if f.name != "recorder"}
        small = _Small(FORMAT_VERSION, rest, head, self._steps.valid(), self._traces.valid())
        with self._tmp.open("wb") as f:
            pickle.dump(small, f, protocol=pickle.HIGHEST_PROTOCOL)
        os.replace(self._tmp, self.path)
        self._written = head.n_steps

    def _open(self, n_trace: int) -> None:
        if self._resume is None:  # a new run: an older checkpoint here must not meet the new side files
            self.path.unlink(missing_ok=True)
            steps_valid = traces_valid = None
        else:
            steps_valid, traces_valid, self._written = self._resume
        self._steps = _Appender(self.steps_path, _STEPS_MAGIC, _STEP, steps_valid)
        self._traces = _Appender(self.traces_path, _TRACES_MAGIC, _trace_dtype(n_trace), traces_valid)

    def close(self) -> None:
        for appender in (self._steps, self._traces):
            if appender is not None:
                appender.file.close()
        self._steps = self._traces = None

    def remove(self) -> None:
        """Close and delete the checkpoint (the mission finished: nothing to resume)."""
        self.close()
        for p in (self.path, self.steps_path, self.traces_path, self._tmp):
            p.unlink(missing_ok=True)


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


def cut_logs(out_dir: Path, ckpt: Checkpoint, epoch_us: int) -> None:
    """Cut the run's logs back to the checkpoint: events.jsonl to its length then, each .tlog (the GCS's
    and the aPad's, stamped `epoch_us` + mission time) and each aPad's event log (stamped with mission
    time) before the checkpoint's mission time."""
    try:
        events = out_dir / EVENTS_NAME
        if events.exists() and events.stat().st_size > ckpt.events_bytes:
            os.truncate(events, ckpt.events_bytes)
        for path in sorted(out_dir.glob("*.tlog")):
            _cut(path, ((stamp, 8 + len(frame), _whole(frame)) for stamp, frame in tlog.frames(path)),
                 epoch_us + ckpt.time_us)
        for path in sorted(out_dir.glob(f"*{apad_logs.EVENTS_SUFFIX}")):
            _cut(path, apad_logs.event_records(path), ckpt.time_us)
    except (OSError, tlog.TlogError) as exc:
        raise CheckpointError(f"cannot cut the logs in {out_dir} back to the checkpoint: {_one_line(exc)}") from None


def _cut(path: Path, records: Iterable[tuple[int, int, bool]], stamp_us: int) -> None:
    """Truncate a log of (stamp, length in bytes, whole) records before the first stamped at or after
    `stamp_us` (logged again after the resume) or cut short by the crash."""
    size, offset = path.stat().st_size, 0
    for stamp, length, whole in records:
        if stamp >= stamp_us or not whole:
            break
        offset += length
    if offset < size:
        os.truncate(path, offset)


def _whole(frame: bytes) -> bool:
    """Whether a .tlog frame is all there (a crash can cut the last one short)."""
    if len(frame) < 3:
        return False
    if frame[0] == mavlink.PROTOCOL_MARKER_V2:
        signature = mavlink.MAVLINK_SIGNATURE_BLOCK_LEN if frame[2] & mavlink.MAVLINK_IFLAG_SIGNED else 0
        return len(frame) == 12 + frame[1] + signature
    return len(frame) == 8 + frame[1]


def restore(world: World, ckpt: Checkpoint) -> None:
    """Put the saved state into a freshly built world whose clock started at `ckpt.time_us` (a wall
    clock has run on a little since: the fleet's next step still falls a step after the saved time)."""
    if ckpt.run_key != run_key(world):
        raise CheckpointError(f"the checkpoint is of run {ckpt.run_key}, not {run_key(world)}")
    if not 0 <= world.clock.now_us - ckpt.time_us <= RESTORE_SLACK_US:
        raise CheckpointError("the world's clock must start at the checkpoint's mission time")
    fleet = world.fleet
    if not (np.array_equal(ckpt.recorder.ids, fleet.recorder.ids)
            and np.array_equal(ckpt.recorder.trace_ids, fleet.recorder.trace_ids)):
        raise CheckpointError("the checkpoint's recorder is of other aMussels than the scenario's")
    fleet.resume(ckpt.fleet_state, ckpt.fleet_rng_state, ckpt.recorder)
    world.link.registry.restore(ckpt.registry)
    v, snap = world.vehicle, ckpt.vehicle
    if v is not None and snap is not None:
        v.state, v.mode, v.armed = snap.state, snap.mode, snap.armed
        v._speed_override_mps = snap.speed_override_mps
        v._set_primitive(snap.primitive)
