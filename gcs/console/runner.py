"""The live console's world thread: it owns the link, the fleet, the embedded SITL aPads and the loops.

The scheduler and the link are not thread-safe, so everything that touches them runs on the one
thread that calls `ConsoleRunner.run()` (the console starts it in a Textual worker thread). The UI
talks to it only through thread-safe doors:

- `LoopControl` flags (pause, stop, strategy), which the loop reads between waits;
- `submit(command)`: a queue of operator commands, executed through `ApadApi` *between* the
  loop's waits (never inside another command's ACK wait), or while the loop is not running;
- `snapshot`: a frozen `Snapshot` (copies) replaced at 10 Hz when something changed;
- `select_apad`: which aPad the operator's commands act on.

The mission itself is a `MissionSession` (`gcs.mission.session`), as in `vil run`: the loops (several
aPads' as processes of one clock, one at a time), checkpoints, resume, time accounting, results.
This runner adds the screen's snapshots and the operator's doors. With several aPads each loop has
its own `LoopControl`, which follows the runner's (pause, stop) at each of its waits, and serves the
commands for its own aPad there, on its own clock, so a command never runs inside another command's
ACK wait for the same aPad, and never two threads at once.

With an output folder the mission checkpoints itself there every `CHECKPOINT_PERIOD_S` of mission
time from the loops' start (deleted once the mission has ended and result.json is written), so
`vil gcs --resume` continues it after a crash: the world is built on a clock starting at the
checkpoint's time, the saved state put back, and each loop first settles what the crash interrupted
(`EnergySharingLoop.run(resume=True)`).

Nothing here imports Textual: tests drive a runner directly.
"""

from __future__ import annotations

import functools
import json
import threading
import time

import numpy as np

from gcs.console.config import ConsoleConfig, ResumePoint, open_world
from gcs.console.link_health import Level, LinkHealth, LossWindow, link_health
from gcs.console.operator import (
    QUIT,
    CommandQueue,
    DockMussel,
    GoToMussel,
    Hold,
    OperatorCommand,
    UndockMussel,
    leave_holding,
    log_whereabouts,
)
from gcs.link.apad_api import ApadApi
from gcs.loop.energy_sharing import EnergySharingLoop, LoopControl
from gcs.mission.checkpoint import Checkpoint, CheckpointError, CheckpointFiles, setup_digest
from gcs.mission.outcome import write_outputs
from gcs.mission.session import MissionSession
from gcs.mission.world import World
from gcs.records.events import Event
from gcs.records.run_folder import RunFolder
from gcs.view.model import END_WORDS, MissionView, area_outline
from gcs.view.snapshot import Snapshot
from missiontime import PacedClock, mm_ss, us_to_s
from mussel_sim.placement import load_area

PUBLISH_PERIOD_S = 0.1  # the UI redraws at 10 Hz at most
SAMPLE_PERIOD_S = 1.0  # one point on the plots per second of mission time


class ConsoleRunner:
    def __init__(self, config: ConsoleConfig, world: World | None = None) -> None:
        """`world`: already opened by `open_world(config)` (so `vil gcs` refuses what it cannot open
        before the console starts); it is handed to the world thread, which owns it from then on."""
        self.config = config
        self.control = LoopControl(paused=config.start_paused)
        self.snapshot: Snapshot | None = None  # replaced whole; readers never see a half-built one
        self.world: World | None = world
        self.apad_ids = tuple(a.system_id for a in config.scenario.apads)
        self.selected = self.apad_ids[0]  # the aPad the operator's commands act on
        self.error: str | None = None
        self.finished = threading.Event()
        # A swarm's loops' own controls, following `control`; one aPad's loop takes `control` itself.
        self._controls = {sysid: LoopControl(paused=self.control.paused) for sysid in self.apad_ids} \
            if len(self.apad_ids) > 1 else {}
        self.session: MissionSession | None = self._open_session(world) if world is not None else None
        self._commands = CommandQueue(swarm=len(self.apad_ids) > 1)
        self._quit = threading.Event()
        self._quit_now = threading.Event()
        self._notice = "connecting" if config.connect else "starting the SITL aPad"
        self._model: MissionView | None = None
        self._last_event: Event | None = None
        self._published: tuple[object, ...] = ()
        # The links as last computed on the world thread, and when (monotonic wall seconds): a UI that
        # sees no new one for a while knows the world thread is stuck, not that the links are fine.
        self.link_status: tuple[LinkHealth, ...] = ()
        self.link_published_s = 0.0
        self._loss = LossWindow()
        self._listening_us = 0
        self._restarts: dict[int, int] = {}
        self._lost: dict[str, bool] = {}
        self._mission_started = False

    @property
    def swarm(self) -> bool:
        return len(self.apad_ids) > 1

    @property
    def loops(self) -> dict[int, EnergySharingLoop]:
        """Every aPad's loop, as it starts."""
        return self.session.loops if self.session is not None else {}

    def _open_session(self, world: World) -> MissionSession:
        """The mission over `world` (a resumed one's saved state put back: `CheckpointError` if it
        is not this world's), each loop with its control and its hook before each wait."""
        config = self.config
        controls = self._controls or {self.apad_ids[0]: self.control}
        for sysid, control in controls.items():
            # Operator commands run between the loop's waits; a quit-now ends it at one (never mid-dock).
            control.before_wait = functools.partial(self._loop_wait, world, sysid)
        resume = config.resume
        files = resume.files if resume is not None else (
            CheckpointFiles(RunFolder(config.out_dir).checkpoint) if config.out_dir is not None else None)
        return MissionSession(world, files, resume.checkpoint if resume is not None else None, controls=controls,
                              setup=setup_digest(config.scenario))

    # --- the UI's doors (any thread) -------------------------------------------------------------

    def submit(self, command: OperatorCommand) -> None:
        """Queue an operator command for the selected aPad; it pauses the loops first."""
        self.set_paused(True)
        self._commands.put(self.selected, command)

    def select_apad(self, sysid: int | None = None) -> int:
        """Pick the aPad the commands act on (None: the next one); the one picked."""
        ids = self.apad_ids
        picked = ids[(ids.index(self.selected) + 1) % len(ids)] if sysid is None else sysid
        if picked not in ids:
            raise ValueError(f"no aPad {sysid}")
        self.selected = picked
        self.log_operator("select_apad", apad=picked)
        return picked

    def set_paused(self, paused: bool) -> None:
        if paused != self.control.paused:
            self.log_operator("pause" if paused else "resume")
        self.control.paused = paused

    def switch_strategy(self, name: str) -> None:
        with self.control.lock:  # one loop takes it from here; a swarm's each get it at their waits
            self.control.strategy = name
        self.log_operator("strategy", strategy=name)

    def log_operator(self, action: str, **fields: object) -> None:
        """An operator action for the event log (written on the world thread, within a tenth of a second)."""
        self._commands.log(action, fields)

    def mission_running(self) -> bool:
        """Whether a loop runs (started and not ended): quitting then interrupts a mission."""
        return self._mission_started and any(self._running(s) for s in self.apad_ids)

    def request_quit(self, now: bool = False) -> None:
        """End the mission, leave the aPads holding, close everything.

        The loops stop at their next safe point: each finishes a collection it has started (an
        aMussel called up is docked, not left floating). `now` ends them at their next wait instead
        (a latch closing finishes on the aPad by itself). Either way the end is bounded and quick
        (`leave_holding`): the aPads hold, the floating aMussels are sent down, the world closes.
        """
        if not self._quit_now.is_set() and (now or not self._quit.is_set()):
            self.log_operator(QUIT, now=now)
        self._quit.set()
        self.control.stop = True
        if now:
            self._quit_now.set()
            self._notice = "quitting now: the aPads hold, floating aMussels are sent down"
        else:
            self._notice = "quitting: the loop finishes the collection it started, then the aPad holds (Q: now)"

    # --- the world thread ------------------------------------------------------------------------

    def run(self) -> None:
        try:
            self.world = world = self.world or open_world(self.config)
            self.session = session = self.session or self._open_session(world)
        except (OSError, ValueError, CheckpointError) as exc:
            self.error = f"cannot start: {exc}"
            self.finished.set()
            return
        try:
            self._run(world, session)
        except Exception as exc:  # shown on the console, not lost in a worker thread
            self.error = f"{type(exc).__name__}: {exc}"
            self._publish(world.clock.now_us)
            raise
        finally:
            session.close()  # a checkpoint left is kept: the mission did not end, so it can be resumed
            world.close()
            self.finished.set()

    def _run(self, world: World, session: MissionSession) -> None:
        s = world.scenario
        clock = world.clock
        source = self.config.connect or f"embedded SITL ({self.config.sitl})"
        model = MissionView(
            world.link.registry, s.apad.system_id, s.mission.pool_threshold, s.mission.duration_s, source,
            world.start.ids.astype(np.int64), area_outline(load_area(s.fleet.area).geometry), apad_ids=self.apad_ids,
            sinking_counts_active=s.mission.sinking_counts_active,
        )
        model.strategy = s.mission.collect_strategy  # until the loop says otherwise
        if self.config.resume is not None:
            self._replay_history(model, self.config.resume.checkpoint)
        self._model = model
        self._listening_us = clock.now_us
        clock.scheduler.every(PUBLISH_PERIOD_S, self._publish, "console.publish", clock.now_us)
        sampling = clock.scheduler.every(SAMPLE_PERIOD_S, lambda now_us: model.sample(us_to_s(now_us)),
                                         "console.sample", clock.now_us)
        if not session.start(functools.partial(self._wait_for_apad, world)):
            return
        if session.shares is not None and session.watch is not None:
            model.set_owner(session.shares.owner)
            session.watch.on_reshare.append(lambda now: model.set_owner(now.owner))
        self._notice = "loop paused: press p to start" if self.control.paused else ""
        while self.control.paused and not self._quit.is_set():
            self._serve(world, world.api, None)
            clock.sleep(PUBLISH_PERIOD_S)
        if not self._quit.is_set():
            self._notice = ""
            self._mission_started = True
            started_s = time.perf_counter()
            end = session.run()
            if self.config.out_dir is not None:  # the mission's figures, as `vil run` writes them
                write_outputs(world, session.result(time.perf_counter() - started_s), RunFolder(self.config.out_dir),
                              session.apad_times, session.apad_record)
            session.finish()
            sampling.active = False  # the plots and the clock stop at the mission's end
            why = END_WORDS.get(end, end)
            self._notice = f"mission ended at {mm_ss(clock.time())}: {why}; the aPad holds (q quits)"
        while not self._quit.is_set():  # telemetry and manual commands go on until the operator quits
            self._serve(world, world.api, None)
            clock.sleep(PUBLISH_PERIOD_S)
        self._commands.flush(world)
        log_whereabouts(world, leave_holding(world, self._set_notice))

    def _loop_wait(self, world: World, sysid: int) -> bool:
        """A loop's hook before each of its waits: follow the operator's pause, stop and strategy,
        run the commands queued for its aPad; True ends it here (quit now)."""
        control, loop = self._controls.get(sysid), self.loops[sysid]
        if control is not None:
            control.paused, control.stop = self.control.paused, self.control.stop
            wanted = self._swarm_strategy()
            if wanted is not None and wanted != loop.status.strategy:
                with control.lock:
                    control.strategy = wanted  # taken at its next planning step
        self._serve(world, loop.api, sysid)
        return self._quit_now.is_set()

    def _replay_history(self, model: MissionView, saved: Checkpoint) -> None:
        """A resumed console shows the mission so far: the events logged up to the checkpoint."""
        out = self.config.out_dir
        if out is None:
            return
        with RunFolder(out).events.open("rb") as f:
            head = f.read(saved.events_bytes)
        for line in head.decode("utf-8", "replace").splitlines():
            try:
                record = json.loads(line)
                model.event(Event(float(record.pop("t_s")), str(record.pop("event")), record))
            except (ValueError, KeyError, TypeError, AttributeError):
                continue  # the console's history is for show; the mission does not depend on it

    def _wait_for_apad(self, world: World, sysid: int) -> bool:
        """Listen for the aPad until it is heard (True) or the operator quits (False, seen within a
        tenth of a second); a notice says so while nothing is heard."""
        since = world.clock.time()
        while True:
            if self._quit.is_set():
                return False
            try:
                world.api.wait_apad(timeout_s=PUBLISH_PERIOD_S, apad_id=sysid)
                return True
            except TimeoutError:
                if world.clock.time() - since >= self.config.connect_timeout_s:
                    who = f"aPad {sysid}" if self.swarm else "aPad"
                    self._notice = f"no {who} heard on {self.config.connect or 'the SITL link'}; still listening"

    def _set_notice(self, text: str) -> None:
        self._notice = text

    def _running(self, sysid: int) -> bool:
        loop = self.loops.get(sysid)
        return loop is not None and loop.status.end_reason is None

    def _serve(self, world: World, api: ApadApi, serving: int | None) -> None:
        """Run queued operator commands through `api` (a world thread only): those for aPad
        `serving`, and those whose aPad has no loop running to serve them (all when None)."""
        self._commands.serve(world, api, serving, self._running, self._set_notice)

    def _watch_links(self, world: World, now_us: int) -> None:
        """The links' health for the UI, and an event (and a notice) for every aPad restart seen."""
        registry = world.link.registry
        self.link_status = link_health(registry, self.apad_ids, now_us, self._listening_us, world.link.codec.signing,
                                       self._loss)
        self.link_published_s = time.monotonic()
        for h in self.link_status:  # into and out of LINK LOST: an event each
            lost = h.level == Level.LOST
            if lost != self._lost.get(h.name, False):
                self._lost[h.name] = lost
                world.events.emit(world.clock.time(), "link_lost" if lost else "link_back", link=h.name,
                                  silent_s=round(h.age_s, 1))
        for sysid in self.apad_ids:
            view = registry.vehicles.get(sysid)
            if view is not None and view.restarts != self._restarts.get(sysid, 0):
                self._restarts[sysid] = view.restarts
                held = list(view.held_before_restart)
                world.events.emit(world.clock.time(), "apad_restart", apad=sysid, held=held,
                                  slots_now=list(view.held()))
                now = ", ".join(map(str, view.held())) or "nothing"
                was = f": it held aMussel {', '.join(map(str, held))} before, its slots report {now} now" \
                    if held else ""
                self._notice = f"aPad {sysid} restarted (its clock went back){was}"

    def _swarm_strategy(self) -> str | None:
        """A swarm's loops do not take the operator's strategy: each is handed it until it has it."""
        with self.control.lock:
            return self.control.strategy

    def _pending_strategy(self) -> str | None:
        wanted = self._swarm_strategy()
        if not self._controls:
            return wanted
        running = [loop for loop in list(self.loops.values()) if loop.status.end_reason is None]
        return wanted if any(loop.status.strategy != wanted for loop in running) else None

    def _publish(self, now_us: int) -> None:
        """Pull new mission events into the model; publish a snapshot if anything changed."""
        model, world = self._model, self.world
        if model is None or world is None:
            return
        self._commands.flush(world)
        self._watch_links(world, now_us)
        self._commands.sink_refused(world)
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
        pending = self._pending_strategy()
        refused = world.link.dropped
        dropped = sum(refused.values())
        key = (model.version, self.control.paused, pending, self._notice + (self.error or ""), self.selected, dropped)
        if key == self._published:
            return
        self._published = key
        notice = f"error: {self.error}" if self.error else self._notice
        top = "".join(f"{reason} ×{n}" for reason, n in refused.most_common(1))
        self.snapshot = model.snapshot(us_to_s(now_us), selected=self.selected, paused=self.control.paused,
                                       pending_strategy=pending, notice=notice, dropped=dropped, dropped_top=top)


__all__ = [
    "ConsoleConfig",
    "ConsoleRunner",
    "DockMussel",
    "GoToMussel",
    "Hold",
    "OperatorCommand",
    "PacedClock",
    "ResumePoint",
    "UndockMussel",
]
