"""The live console's world thread: it owns the link, the fleet, an embedded SITL aPad and the loop.

The scheduler and the link are not thread-safe, so everything that touches them runs on the one
thread that calls `ConsoleRunner.run()` (the console starts it in a Textual worker thread). The UI
talks to it only through thread-safe doors:

- `LoopControl` flags (pause, stop, strategy), which the loop reads between waits;
- `submit(command)`: a queue of operator commands, executed through `ApadApi` *between* the
  loop's waits (never inside another command's ACK wait), or while the loop is not running;
- `snapshot`: a frozen `Snapshot` (copies) replaced at 10 Hz when something changed.

With an output folder the mission checkpoints itself there every `CHECKPOINT_PERIOD_S` of mission
time (deleted when the loop ends), so `vil gcs --resume` continues it after a crash: the world is
built on a clock starting at the checkpoint's time, the saved state put back, and the loop first
settles what the crash interrupted (`EnergySharingLoop.run(resume=True)`).

Nothing here imports Textual: tests drive a runner directly.
"""

from __future__ import annotations

import json
import queue
import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from apad_sitl.vocabulary import Latch, Primitive, Progress
from gcs.api import CommandError
from gcs.console.model import ConsoleModel, Snapshot, area_outline
from gcs.mission.accounting import account
from gcs.mission.loop import EnergySharingLoop, LoopControl
from gcs.mission.scenario import Scenario
from gcs.mission.world import LinkOptions, World, build_world
from gcs.records import checkpoint
from gcs.records.checkpoint import CHECKPOINT_NAME, CHECKPOINT_PERIOD_S, Checkpoint, CheckpointFiles
from gcs.records.events import EVENTS_NAME, Event
from missiontime import Clock, PacedClock, Task, WallClock, seconds_to_us, unix_time_us, us_to_s
from mussel_sim.placement import load_area
from mussel_sim.vocabulary import MusselCommand, MusselState

PUBLISH_PERIOD_S = 0.1  # the UI redraws at 10 Hz at most
SAMPLE_PERIOD_S = 1.0  # one point on the plots per second of mission time
QUIT_DOCK_WAIT_S = 120.0  # quitting waits this long at most for a dock/undock to finish
SINK_MARGIN_S = 10.0  # quit-now waits for surfacing aMussels to float (then sinks them), this much extra


# --- operator commands: plain values the UI puts on the queue ---------------------------------


@dataclass(frozen=True)
class Hold:
    """Abort whatever the aPad does: Hold Position."""


@dataclass(frozen=True)
class GoToMussel:
    mussel_id: int


@dataclass(frozen=True)
class DockMussel:
    mussel_id: int


@dataclass(frozen=True)
class UndockMussel:
    mussel_id: int


OperatorCommand = Hold | GoToMussel | DockMussel | UndockMussel


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


def open_world(config: ConsoleConfig) -> World:
    """The mission's world on the console's clock, with a remote aPad or the embedded SITL one; a
    resumed one starts at the checkpoint's time with its state put back (`CheckpointError` if it
    is another run's)."""
    if (config.connect is None) == (config.sitl is None):
        raise ValueError("give exactly one of connect or sitl")
    saved = config.resume.checkpoint if config.resume is not None else None
    start_us = saved.time_us if saved is not None else 0
    clock: Clock = WallClock(start_us=start_us) if config.speed is None else PacedClock(config.speed, start_us=start_us)
    options = LinkOptions(connect=config.connect, sitl_medium=config.sitl or "memory", signing_key=config.signing_key,
                          bridge=config.bridge)
    epoch_us = unix_time_us() if config.epoch_us is None else config.epoch_us
    world = build_world(config.scenario, clock, config.out_dir, options, epoch_us=epoch_us,
                        mission_start_us=0 if saved is not None else None, append_logs=saved is not None)
    if saved is not None:
        try:
            checkpoint.restore(world, saved)
        except checkpoint.CheckpointError:
            world.close()
            raise
    return world


class ConsoleRunner:
    def __init__(self, config: ConsoleConfig, world: World | None = None) -> None:
        """`world`: already opened by `open_world(config)` (so `vil gcs` refuses what it cannot open
        before the console starts); it is handed to the world thread, which owns it from then on."""
        self.config = config
        self.control = LoopControl(paused=config.start_paused)
        self.snapshot: Snapshot | None = None  # replaced whole; readers never see a half-built one
        self.world: World | None = world
        self.loop: EnergySharingLoop | None = None
        self.error: str | None = None
        self.finished = threading.Event()
        self._commands: queue.SimpleQueue[OperatorCommand] = queue.SimpleQueue()
        self._quit = threading.Event()
        self._quit_now = threading.Event()
        self._notice = "connecting" if config.connect else "starting the SITL aPad"
        self._model: ConsoleModel | None = None
        self._last_event: Event | None = None
        self._published: tuple[int, bool, str | None, str] = (-1, False, None, "")
        self._checkpoints: CheckpointFiles | None = config.resume.files if config.resume else None

    # --- the UI's doors (any thread) -------------------------------------------------------------

    def submit(self, command: OperatorCommand) -> None:
        """Queue an operator command; a command that moves the aPad pauses the loop first."""
        self.control.paused = True
        self._commands.put(command)

    def set_paused(self, paused: bool) -> None:
        self.control.paused = paused

    def switch_strategy(self, name: str) -> None:
        with self.control.lock:
            self.control.strategy = name

    def request_quit(self, now: bool = False) -> None:
        """End the mission, leave the aPad holding, close everything.

        The loop stops at its next safe point: it finishes a collection it has started (an aMussel
        called up is docked, not left floating). `now` ends it at the loop's next wait instead,
        sends any surfaced aMussel back down, and still never interrupts a dock or undock.
        """
        self._quit.set()
        self.control.stop = True
        if now:
            self._quit_now.set()
            self._notice = "quitting now: the aPad holds once no dock is in progress"
        else:
            self._notice = "quitting: the loop finishes the collection it started, then the aPad holds (Q: now)"

    # --- the world thread ------------------------------------------------------------------------

    def run(self) -> None:
        try:
            self.world = world = self.world or open_world(self.config)
        except (OSError, ValueError) as exc:
            self.error = f"cannot start: {exc}"
            self.finished.set()
            return
        try:
            self._run(world)
        except Exception as exc:  # shown on the console, not lost in a worker thread
            self.error = f"{type(exc).__name__}: {exc}"
            self._publish(world.clock.now_us)
            raise
        finally:
            if self._checkpoints is not None:
                self._checkpoints.close()  # kept: the mission did not end, so it can be resumed
            world.close()
            self.finished.set()

    def _run(self, world: World) -> None:
        s = world.scenario
        clock = world.clock
        source = self.config.connect or f"embedded SITL ({self.config.sitl})"
        model = ConsoleModel(
            world.link.registry, s.apad.system_id, s.mission.pool_threshold, s.mission.duration_s, source,
            world.start.ids.astype(np.int64), area_outline(load_area(s.fleet.area).geometry),
        )
        model.strategy = s.mission.collect_strategy  # until the loop says otherwise
        if self.config.resume is not None:
            self._replay_history(model, self.config.resume.checkpoint)
        self._model = model
        clock.scheduler.every(PUBLISH_PERIOD_S, self._publish, "console.publish", clock.now_us)
        clock.scheduler.every(SAMPLE_PERIOD_S, lambda now_us: model.sample(us_to_s(now_us)), "console.sample",
                              clock.now_us)
        if not self._wait_for_apad(world):
            return
        world.request_telemetry()
        self._notice = "loop paused: press p to start" if self.control.paused else ""
        while self.control.paused and not self._quit.is_set():
            self._serve()
            clock.sleep(PUBLISH_PERIOD_S)
        if not self._quit.is_set():
            # Operator commands run between the loop's waits; a quit-now ends it at one (never mid-dock).
            self.control.before_wait = lambda: self._before_wait(world)
            self.loop = loop = world.mission_loop(self.control)
            if self.config.resume is not None:
                loop.status = self.config.resume.checkpoint.loop_status
            task = self._start_checkpoints(world, loop)
            self._notice = ""
            end = loop.run(resume=self.config.resume is not None)
            if task is not None:
                task.active = False
            if self._checkpoints is not None:
                self._checkpoints.remove()  # the mission ended: nothing to resume
                self._checkpoints = None
            self._notice = f"mission ended: {end}"
        while not self._quit.is_set():  # telemetry and manual commands go on until the operator quits
            self._serve()
            clock.sleep(PUBLISH_PERIOD_S)
        self._leave_holding(world)
        self._log_whereabouts(world)

    def _start_checkpoints(self, world: World, loop: EnergySharingLoop) -> Task | None:
        """Save the mission every `CHECKPOINT_PERIOD_S` of mission time (with an output folder)."""
        out = self.config.out_dir
        if out is None:
            return None
        if self._checkpoints is None:
            self._checkpoints = CheckpointFiles(out / CHECKPOINT_NAME)
        files = self._checkpoints
        return world.clock.scheduler.every(
            CHECKPOINT_PERIOD_S, lambda now_us: checkpoint.save(files, checkpoint.capture(world, loop)),
            "console.checkpoint", world.clock.now_us + seconds_to_us(CHECKPOINT_PERIOD_S))

    def _replay_history(self, model: ConsoleModel, saved: Checkpoint) -> None:
        """A resumed console shows the mission so far: the events logged up to the checkpoint."""
        out = self.config.out_dir
        if out is None:
            return
        with (out / EVENTS_NAME).open("rb") as f:
            head = f.read(saved.events_bytes)
        for line in head.decode("utf-8", "replace").splitlines():
            try:
                record = json.loads(line)
                model.event(Event(float(record.pop("t_s")), str(record.pop("event")), record))
            except (ValueError, KeyError, TypeError, AttributeError):
                continue  # the console's history is for show; the mission does not depend on it

    def _log_whereabouts(self, world: World) -> None:
        """Where every aMussel is as the console quits: on the seabed, on a slot, or lost (and why)."""
        homes = {m: (h.lat, h.lon) for m, h in world.homes.items()}
        accounts = account(world.fleet.state, world.frame, homes, world.link.vehicles)
        world.events.emit(world.clock.time(), "whereabouts",
                          seabed=[a.mussel_id for a in accounts if a.where == "seabed"],
                          slot=[a.mussel_id for a in accounts if a.where == "slot"],
                          lost={str(a.mussel_id): a.detail for a in accounts if a.lost})

    def _before_wait(self, world: World) -> bool:
        """The loop's hook: run queued operator commands; True ends the mission (quit now, no dock running)."""
        self._serve()
        return self._quit_now.is_set() and not _docking(world)

    def _wait_for_apad(self, world: World) -> bool:
        while not self._quit.is_set():
            try:
                world.api.wait_apad(timeout_s=self.config.connect_timeout_s, apad_id=world.scenario.apad.system_id)
                return True
            except TimeoutError:
                self._notice = f"no aPad heard on {self.config.connect or 'the SITL link'}; still listening"
        return False

    def _leave_holding(self, world: World) -> None:
        """Quit: let a dock or undock finish, then hold (the loop already did if it ran)."""
        api, apad = world.api, world.scenario.apad.system_id
        if apad not in world.link.vehicles:
            return
        deadline = world.clock.time() + QUIT_DOCK_WAIT_S
        while _docking(world) and world.clock.time() < deadline:
            self._notice = "quitting: waiting for the dock to finish"
            world.clock.sleep(0.2)
        try:
            api.hold(apad)
            if self._quit_now.is_set():
                self._sink_surfaced(world)
            world.clock.sleep(0.5)  # let the last commands go out before the link closes
        except CommandError as exc:
            self.error = str(exc)

    def _sink_surfaced(self, world: World) -> None:
        """Nothing left floating where it cannot work: a surfacing aMussel is sunk once it floats."""
        api, apad = world.api, world.scenario.apad.system_id
        deadline = world.clock.time() + world.scenario.fleet.surfacing_time_s + SINK_MARGIN_S
        while world.clock.time() < deadline:
            docked = {s.mussel_id for s in api.slots(apad) if s.mussel_id}
            up = {m: api.mussels[m].state for m in api.mussels.select((MusselState.SURFACING, MusselState.FLOATING))
                  if m not in docked}
            if not up:
                return
            self._notice = f"quitting now: sending aMussel {', '.join(map(str, sorted(up)))} back down"
            for mussel_id, state in up.items():
                if state == MusselState.FLOATING:
                    api.command_mussel(mussel_id, MusselCommand.SINK, apad)
            world.clock.sleep(1.0)

    def _serve(self) -> None:
        """Run queued operator commands through the aPad API (world thread only)."""
        world = self.world
        assert world is not None
        while True:
            try:
                command = self._commands.get_nowait()
            except queue.Empty:
                return
            try:
                self._notice = self._execute(world, command)
            except (CommandError, LookupError) as exc:
                self._notice = f"refused: {exc}"

    def _execute(self, world: World, command: OperatorCommand) -> str:
        api, apad = world.api, world.scenario.apad.system_id
        match command:
            case Hold():
                api.hold(apad)
                return "override: aPad holding, loop paused"
            case GoToMussel(mussel_id):
                api.go_to(api.get_location(mussel_id), apad_id=apad)
                return f"manual: going to aMussel {mussel_id}, loop paused"
            case DockMussel(mussel_id):
                free = api.apad(apad).free_slots()
                if not free:
                    return "refused: no free slot"
                api.command_mussel(mussel_id, MusselCommand.SURFACE, apad)
                api.docking(True, free[0], mussel_id, apad)
                return f"manual: docking aMussel {mussel_id} in slot {free[0]}, loop paused"
            case UndockMussel(mussel_id):
                slots = [s.slot for s in api.slots(apad) if s.mussel_id == mussel_id and s.latch == Latch.LATCHED]
                if not slots:
                    return f"refused: aMussel {mussel_id} is not docked"
                api.docking(False, slots[0], mussel_id, apad)
                return f"manual: undocking aMussel {mussel_id} from slot {slots[0]}, loop paused"
        raise AssertionError(command)

    def _publish(self, now_us: int) -> None:
        """Pull new mission events into the model; publish a snapshot if anything changed."""
        model, world = self._model, self.world
        if model is None or world is None:
            return
        events = world.events.events
        fresh: list[Event] = []
        for ev in reversed(events):
            if ev is self._last_event:
                break
            fresh.append(ev)
        for ev in reversed(fresh):
            model.event(ev)
        if events:
            self._last_event = events[-1]
        with self.control.lock:
            pending = self.control.strategy
        key = (model.version, self.control.paused, pending, self._notice + (self.error or ""))
        if key == self._published:
            return
        self._published = key
        notice = f"error: {self.error}" if self.error else self._notice
        self.snapshot = model.snapshot(us_to_s(now_us), paused=self.control.paused, pending_strategy=pending,
                                       notice=notice)


def _docking(world: World) -> bool:
    view = world.link.vehicles.get(world.scenario.apad.system_id)
    return view is not None and view.primitive.primitive in (Primitive.DOCK, Primitive.UNDOCK) and (
        view.primitive.progress == Progress.IN_PROGRESS
    )


__all__ = [
    "ConsoleConfig",
    "ConsoleRunner",
    "DockMussel",
    "GoToMussel",
    "Hold",
    "OperatorCommand",
    "ResumePoint",
    "UndockMussel",
]
