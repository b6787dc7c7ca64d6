"""What a live console is given, and the mission's world it opens from that (`open_world`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from gcs.mission.checkpoint import Checkpoint, CheckpointFiles
from gcs.mission.world import LinkOptions, World, build_world
from gcs.scenario.reader import Scenario
from missiontime import Clock, PacedClock, WallClock, unix_time_us


@dataclass(frozen=True)
class ResumePoint:
    """A crashed console mission to continue: its checkpoint's files (the same instance goes on
    saving, it knows where the side files' valid rows end) and what they held."""

    files: CheckpointFiles
    checkpoint: Checkpoint


@dataclass(frozen=True)
class ConsoleConfig:
    scenario: Scenario
    connect: str | None = None  # udp:HOST:PORT of a real or separate SITL aPad
    sitl: str | None = None  # embedded SITL aPad: "memory" (in-memory pair) or "udp" (localhost socket)
    speed: float | None = None  # None: wall clock; else a PacedClock at this speed (SITL only)
    out_dir: Path | None = None  # gcs.tlog and events.jsonl, replayable with `vil replay`
    start_paused: bool = False  # connect and show, but start the loop only on resume
    connect_timeout_s: float = 5.0
    signing_key: bytes | None = None  # MAVLink 2 signing on the aPad link (`vil gcs --signing-key`)
    epoch_us: int | None = None  # Unix time of mission time 0 in the logs (None: now)
    resume: ResumePoint | None = None  # continue this checkpoint's mission (`vil gcs --resume`)
    bridge: str | None = None  # where real aMussels report (`vil gcs --bridge`)
    modem: str | None = None  # the GCS's nanomodem's serial device (`vil gcs --modem`)
    sea: str | None = None  # udp:HOST:PORT of `vil modem --sea`, for the simulated aMussels' modems (`--sea`)
    fail_apads: tuple[tuple[int, float], ...] = ()  # (aPad, mission s): that embedded SITL aPad falls silent then


def open_world(config: ConsoleConfig) -> World:
    """The mission's world on the console's clock, with remote aPads or the embedded SITL ones; a
    resumed one starts at the checkpoint's time (its session puts the saved state back)."""
    if (config.connect is None) == (config.sitl is None):
        raise ValueError("give exactly one of connect or sitl")
    saved = config.resume.checkpoint if config.resume is not None else None
    start_us = saved.time_us if saved is not None else 0
    clock: Clock = WallClock(start_us=start_us) if config.speed is None else PacedClock(config.speed, start_us=start_us)
    options = LinkOptions(connect=config.connect, sitl_medium=config.sitl or "memory", signing_key=config.signing_key,
                          bridge=config.bridge, fail_apads=config.fail_apads, modem=config.modem, sea=config.sea)
    epoch_us = unix_time_us() if config.epoch_us is None else config.epoch_us
    return build_world(config.scenario, clock, config.out_dir, options, epoch_us=epoch_us,
                       mission_start_us=0 if saved is not None else None, append_logs=saved is not None)
