"""Crash-safe checkpoints of a running mission, so a killed GCS continues the same mission.

A checkpoint holds what cannot be heard again from the vehicles: mission time, the simulated
fleet (state arrays, its rng, the uptime recorder), the scenario loop's status (phase, strategy,
cost, cycles), and what the GCS knew (aMussel and aPad views). In lockstep the SITL aPad runs
in this process, so its state (hull, primitive, latches, mode) is saved too; in the field the aPad
is its own vehicle and keeps its own state across a GCS crash, so `vehicle` is None.

Written atomically (temp file, then `os.replace`): a kill -9 at any instant leaves either the
previous checkpoint or the new one, never half of one. No fsync: the kernel keeps the data of a
killed process; an fsync per checkpoint cost more than the mission (power loss is not covered).
Pickle is fine here: the file is our own, written and read by the same version (checked), in the
run's folder.

For the console (`vil gcs --resume`): `capture(world, loop)` / `save(path, ckpt)` while it runs,
`load(path)` then `restore(world, ckpt)` on a world built with `mission_start_us=0`,
`start_us=ckpt.time_us` and `append_logs=True`, and `loop.run(resume=True)`.
"""

from __future__ import annotations

import os
import pickle
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from apad_sitl.primitives import PrimitiveState
from apad_sitl.vehicle import VehicleState
from gcs.link.registry import VehicleRegistry
from gcs.mission.loop import LoopStatus
from mussel_sim.fleet import FleetState
from mussel_sim.recorder import Recorder

if TYPE_CHECKING:
    from gcs.mission.loop import EnergySharingLoop
    from gcs.world import World

CHECKPOINT_NAME = "checkpoint.pkl"
CHECKPOINT_PERIOD_S = 10.0  # mission time between checkpoints
FORMAT_VERSION = 1


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
    recorder: Recorder
    loop_status: LoopStatus
    registry: VehicleRegistry  # what the GCS had heard: the aPads' views and the aMussel table
    vehicle: VehicleSnapshot | None


def run_key(world: World) -> tuple[str, str, int]:
    s = world.scenario
    return (s.name, s.mission.collect_strategy, s.seed)


def capture(world: World, loop: EnergySharingLoop) -> Checkpoint:
    v = world.vehicle
    snapshot = None
    if v is not None:
        snapshot = VehicleSnapshot(v.state, v.primitive, v.mode, v.armed, v._speed_override_mps)
    fleet = world.fleet
    return Checkpoint(
        FORMAT_VERSION, run_key(world), world.clock.now_us, fleet.state, fleet.rng.bit_generator.state,
        fleet.recorder, loop.status, world.link.registry, snapshot,
    )


def save(path: Path, ckpt: Checkpoint) -> None:
    """Write `ckpt` to `path` atomically."""
    tmp = path.with_name(path.name + ".tmp")
    with tmp.open("wb") as f:
        pickle.dump(ckpt, f, protocol=pickle.HIGHEST_PROTOCOL)
    os.replace(tmp, path)


def load(path: Path) -> Checkpoint:
    try:
        with path.open("rb") as f:
            ckpt = pickle.load(f)
    except FileNotFoundError:
        raise CheckpointError(f"no checkpoint to resume from: {path} does not exist") from None
    except (OSError, pickle.UnpicklingError, EOFError, AttributeError, ImportError) as exc:
        raise CheckpointError(f"cannot read checkpoint {path}: {exc}") from None
    if not isinstance(ckpt, Checkpoint) or ckpt.version != FORMAT_VERSION:
        raise CheckpointError(f"{path} is not a checkpoint of this version of vil")
    return ckpt


def restore(world: World, ckpt: Checkpoint) -> None:
    """Put the saved state into a freshly built world whose clock stands at `ckpt.time_us`."""
    if ckpt.run_key != run_key(world):
        raise CheckpointError(f"the checkpoint is of run {ckpt.run_key}, not {run_key(world)}")
    if world.clock.now_us != ckpt.time_us:
        raise CheckpointError("the world's clock must start at the checkpoint's mission time")
    fleet = world.fleet
    fleet.state = ckpt.fleet_state
    fleet.rng.bit_generator.state = ckpt.fleet_rng_state
    fleet.recorder = ckpt.recorder
    world.link.registry = ckpt.registry
    v, snap = world.vehicle, ckpt.vehicle
    if v is not None and snap is not None:
        v.state, v.mode, v.armed = snap.state, snap.mode, snap.armed
        v._speed_override_mps = snap.speed_override_mps
        v._set_primitive(snap.primitive)
