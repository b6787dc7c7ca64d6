"""Crash-safe checkpoints of a running mission, so a killed GCS continues the same mission.

A checkpoint holds what cannot be heard again from the vehicles: mission time, the simulated
fleet (state arrays, its rng, the uptime recorder), every aPad loop's status (phase, strategy,
cost, cycles), with several aPads who serves whom (`FleetShares`, the retired aPads), and what the
GCS knew (aMussel and aPad views). In lockstep the SITL aPads run in this process, so their state
(hull, primitive, latches, mode) is saved too; in the field an aPad is its own vehicle and keeps its
own state across a GCS crash, so `vehicles` is empty. It also keeps how long each log was
(`log_sizes`) and a `fingerprint` of the mission's state at that instant.

Two ways back (`gcs.mission.session`): a lockstep mission is deterministic, so it resumes by
replaying from the start with its logs muted to the checkpoint's instant, checking the
fingerprint there, and going on: its results are those of a run never interrupted. A console
mission (wall clock, an operator) cannot be replayed: the saved state is put into a new world whose
clock starts at the checkpoint's time (`restore`), and each loop first settles what the crash
interrupted (`EnergySharingLoop.run(resume=True)`). Either way `cut_logs` first cuts every log back
to its length at the checkpoint, so each event and message is in the logs once.

A save costs the same at any mission time. What grows with the mission (the recorder's rows: active
count and time per step, battery and state trace rows) is appended to two side files, `checkpoint.steps` and
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
run's folder; a missing, short or garbled side file, or one of an older version, is a `CheckpointError`.
"""

from __future__ import annotations

import copy
import hashlib
import os
import pickle
import struct
import zlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, fields
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

import numpy as np

from apad_sitl.energy_counters import EnergyCounters
from apad_sitl.primitives import PrimitiveState
from apad_sitl.vehicle import VehicleState
from gcs.link.registry import VehicleRegistry
from gcs.loop.control import LoopStatus
from gcs.records.run_folder import EVENTS, RunFolder
from gcs.swarm.shares import FleetShares
from mussel_sim.fleet_state import FleetState
from mussel_sim.recorder import Recorder, RecorderHead, RecorderRows

if TYPE_CHECKING:
    from gcs.mission.world import World
    from gcs.scenario.reader import Scenario

# Mission time between checkpoints. On the wall clock (a console) a restore loses up to this much of
# the mission. In lockstep a resume replays the mission from its start to the checkpoint whatever the
# period, so the period buys nothing there but saves: a minute of mission time is a tenth of a second
# of wall at a real-time factor of 500, and a day's mission saves 1,440 times, not 8,640.
CHECKPOINT_PERIOD_S = 10.0
LOCKSTEP_CHECKPOINT_PERIOD_S = 60.0
FORMAT_VERSION = 9  # 9: the loops count their failed dockings (LoopStatus.failed_dockings, off_position)
RESTORE_SLACK_US = 30_000_000  # a wall clock started at the checkpoint's time runs on while the world is built
STEPS_SUFFIX = ".steps"  # side files beside the checkpoint
TRACES_SUFFIX = ".traces"


class CheckpointError(Exception):
    """No usable checkpoint; the message is one line for the user."""


@dataclass(frozen=True)
class VehicleSnapshot:
    """An embedded SITL aPad."""

    state: VehicleState
    primitive: PrimitiveState
    mode: int
    armed: bool
    speed_override_mps: float
    energy: EnergyCounters


@dataclass(frozen=True)
class Checkpoint:
    version: int
    run_key: tuple[str, str, int]  # scenario, collection strategy, seed: a checkpoint resumes only its own run
    time_us: int  # mission time
    fleet_state: FleetState
    fleet_rng_state: dict[str, Any]
    recorder: Recorder  # the live one at capture (not copied: save at once); rebuilt by load
    loop_statuses: dict[int, LoopStatus]  # by aPad system id
    registry: VehicleRegistry  # what the GCS had heard: the aPads' views and the aMussel table
    vehicles: dict[int, VehicleSnapshot]  # the embedded SITL aPads, by system id
    shares: FleetShares | None  # several aPads: who serves whom
    retired: frozenset[int]  # several aPads: those whose loop has ended for good
    log_sizes: dict[str, int]  # each log's length, by its file name in the run folder
    fingerprint: str  # the mission's state at `time_us`: a replay must arrive at the same
    setup: str  # `setup_digest` of what the mission was started with: a replay needs the same

    @property
    def events_bytes(self) -> int:
        """How long the mission's event log was."""
        return self.log_sizes.get(EVENTS, 0)


def scenario_key(s: Scenario) -> tuple[str, str, int]:
    """The run a scenario makes: a checkpoint resumes only its own."""
    return (s.name, s.mission.collect_strategy, s.seed)


def run_key(world: World) -> tuple[str, str, int]:
    return scenario_key(world.scenario)


def setup_digest(scenario: Scenario, options: object = None) -> str:
    """What a mission was started with, as a digest: the scenario with every override, and the link's
    options (faults, failing aPads, signing) where they shape the mission."""
    return hashlib.sha256(repr((scenario, options)).encode()).hexdigest()


def check_setup(ckpt: Checkpoint, setup: str) -> None:
    """A checkpoint resumes only the mission started as this one is (flags and scenario alike)."""
    if ckpt.setup != setup:
        raise CheckpointError("the checkpoint's mission was started with other settings (scenario file, "
                              "--duration, --fail-apad, link faults ...): resume with the same ones")


def fingerprint(world: World, statuses: Mapping[int, LoopStatus]) -> str:
    """A digest of the mission's state now: the fleet's arrays, the recorder's step count, each
    loop's cost, cycles, phase and dockings, each embedded aPad's hull, primitive and mode. Equal
    digests at one instant: a replay has arrived where the checkpointed run was. (Not the event log's
    length: a resumed run logged `mission_resume`.)"""
    digest = hashlib.sha256()
    state = world.fleet.state
    for f in fields(state):
        value = getattr(state, f.name)
        digest.update(value.tobytes() if isinstance(value, np.ndarray) else repr(value).encode())
    digest.update(repr((world.clock.now_us, world.fleet.recorder.head().n_steps)).encode())
    for sysid, st in sorted(statuses.items()):
        digest.update(repr((sysid, round(st.cost_m, 6), st.cycles, str(st.phase), st.dockings)).encode())
    for sysid, v in sorted(world.vehicles.items()):
        digest.update(repr((sysid, v.state, v.primitive, v.mode, v.armed)).encode())
    return digest.hexdigest()


def capture(
    world: World, statuses: Mapping[int, LoopStatus], shares: FleetShares | None = None,
    retired: frozenset[int] = frozenset(), setup: str = "",
) -> Checkpoint:
    vehicles = {sysid: VehicleSnapshot(v.state, v.primitive, v.mode, v.armed, v.speed_override_mps,
                                       copy.copy(v.energy_counters))
                for sysid, v in world.vehicles.items()}
    fleet = world.fleet
    # The registry, the statuses and the shares go in live, not copied: `save` pickles a capture at once.
    return Checkpoint(
        FORMAT_VERSION, run_key(world), world.clock.now_us, fleet.state, dict(fleet.rng.bit_generator.state),
        fleet.recorder, dict(statuses), world.link.registry, vehicles, shares, retired, world.log_sizes(),
        fingerprint(world, statuses), setup,
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
    return np.dtype([("step", "<i8"), ("u", "<f4", (n_trace,)), ("s", "u1", (n_trace,))])


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
                            traces["step"].astype(np.int64), traces["u"].astype(np.float32),
                            traces["s"].astype(np.uint8))
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
        traces["s"] = new.trace_state if new.trace_state is not None else 0
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


def cut_logs(folder: RunFolder, ckpt: Checkpoint) -> None:
    """Cut every log of the run back to its length at the checkpoint (what the crashed run logged
    after it is logged again by the resumed one). Every log is checked before any is cut: a name that
    is not a file of the folder, or a log shorter than the checkpoint says (not this run's), leaves
    them all as they are."""
    try:
        cuts = []
        for name, size in sorted(ckpt.log_sizes.items()):
            path = folder.path / name
            if Path(name).name != name or not isinstance(size, int) or size < 0:
                raise CheckpointError(f"checkpoint {folder.checkpoint} names a log it cannot have: {name!r}")
            if path.stat().st_size < size:
                raise CheckpointError(f"{path} is shorter than at the checkpoint: not the log of this run")
            cuts.append((path, size))
        for path, size in cuts:
            os.truncate(path, size)
    except FileNotFoundError as exc:
        raise CheckpointError(f"a log of the checkpointed run is missing: {exc.filename}") from None
    except OSError as exc:
        raise CheckpointError(f"cannot cut the logs in {folder.path} back to the checkpoint: "
                              f"{_one_line(exc)}") from None


def restore(world: World, ckpt: Checkpoint) -> None:
    """Put the saved fleet, registry and embedded aPads into a freshly built world whose clock started at
    `ckpt.time_us` (a wall clock has run on a little since: the fleet's next step still falls a step
    after the saved time). The loops' statuses and the shares are the session's to hand on."""
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
    for sysid, snap in ckpt.vehicles.items():
        v = world.vehicles.get(sysid)
        if v is None:
            continue  # a real aPad now where the checkpoint had a SITL one: it keeps its own state
        v.apad.restore(snap.state, snap.primitive, snap.mode, snap.armed, snap.speed_override_mps,
                       copy.copy(snap.energy))
