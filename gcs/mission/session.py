"""One mission, start to end, for every front end: `vil run` (one aPad or several), `vil gcs`, `vil sweep`.

`MissionSession` owns the mission's lifecycle over a built world (`gcs.mission.world`), once:

    MissionSession(world, ...)  a checkpoint's state put back (console) or the logs muted for a
                                replay (lockstep); each aPad's time accounted from here
    start(wait)                 wait for each aPad (the front end's way), ask for its telemetry,
                                share the fleet among several aPads, checkpoint every 10 s
    run()                       every aPad's loop to the mission's end: one on the world's clock,
                                several as processes of one clock (`missiontime.processes`)
    outcome() / result(wall_s)  the loops, shares and times; the run's figures (result.json)

Resuming after a crash (`gcs.mission.checkpoint`): in lockstep the mission is deterministic, so the
session replays it from the start with the logs muted (they hold that stretch already), checks at the
checkpoint's instant that it arrived at the same state (its fingerprint), unmutes the logs, logs
`mission_resume` and goes on: results as if never interrupted, each event written once. On the
console's wall clock the saved state is restored instead and each loop settles what the crash
interrupted first (`EnergySharingLoop.run(resume=True)`).

The front ends add only their own: `vil run` its progress bar, the console its screen and the
operator's command queue (`LoopControl` per aPad and its `before_wait` hook).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping

from gcs.loop.control import EndReason, LoopControl, LoopStatus
from gcs.loop.energy_sharing import EnergySharingLoop
from gcs.mission import apad_record, checkpoint
from gcs.mission.checkpoint import CHECKPOINT_PERIOD_S, Checkpoint, CheckpointError, CheckpointFiles
from gcs.mission.outcome import Outcome, collect_result
from gcs.mission.time_accounting import ApadTimes, track
from gcs.mission.world import World
from gcs.results.run_result import RunResult
from gcs.swarm.shares import FleetShares, SwarmWatch
from missiontime import Clock, Task, seconds_to_us
from missiontime.event_clock import EventClock
from missiontime.processes import Processes

APAD_WAIT_S = 10.0  # lockstep: an embedded aPad is heard at once; this bounds a broken one

WaitFn = Callable[[int], bool]  # wait for aPad `sysid` to be heard; False: give up (the operator quit)


class MissionSession:
    """One mission over `world`. `checkpoints`: save the mission there every `checkpoint_period_s` of
    mission time (removed once it ends). `saved`: resume from this checkpoint, by replaying to it
    (`replay`, lockstep) or by restoring it; either way it must have been started with the same `setup`
    (`checkpoint.setup_digest`). `controls`: each aPad's `LoopControl` (the console's)."""

    def __init__(
        self, world: World, checkpoints: CheckpointFiles | None = None, saved: Checkpoint | None = None,
        replay: bool = False, controls: Mapping[int, LoopControl] | None = None, setup: str = "",
        checkpoint_period_s: float = CHECKPOINT_PERIOD_S,
    ) -> None:
        self.world = world
        self.checkpoint_period_s = checkpoint_period_s
        self.apad_ids = tuple(a.system_id for a in world.scenario.apads)
        self.loops: dict[int, EnergySharingLoop] = {}
        self.shares: FleetShares | None = None
        self.watch: SwarmWatch | None = None
        self._checkpoints = checkpoints
        self._saved = saved
        self._replaying = saved is not None and replay
        self._controls = dict(controls or {})
        self._setup = setup
        self._task: Task | None = None
        if saved is not None:
            checkpoint.check_setup(saved, setup)
        if saved is not None and not replay:  # the console's way back: the saved state put in
            checkpoint.restore(world, saved)
            self._statuses: dict[int, LoopStatus] = dict(saved.loop_statuses)
        else:
            self._statuses = {}
        self.apad_times: dict[int, ApadTimes] = {
            sysid: self._statuses[sysid].apad_time_us if sysid in self._statuses else {} for sysid in self.apad_ids}
        if self._replaying:
            world.mute_logs(True)
        track(world, self.apad_times)
        self.apad_record = apad_record.start(world, complete=not self.resuming)

    @property
    def swarm(self) -> bool:
        return len(self.apad_ids) > 1

    @property
    def resuming(self) -> bool:
        """Whether the loops settle a crash first (a restored checkpoint, not a replay)."""
        return self._saved is not None and not self._replaying

    def start(self, wait: WaitFn | None = None) -> bool:
        """Wait for each aPad (`wait`, default bounded by `APAD_WAIT_S`), request its telemetry, share
        the fleet (several aPads). False if `wait` gave up."""
        world = self.world
        for sysid in self.apad_ids:
            if wait is None:
                world.api.wait_apad(timeout_s=APAD_WAIT_S, apad_id=sysid)
            elif not wait(sysid):
                return False
            world.request_telemetry(apad_id=sysid)
        if self.swarm:
            self._share_fleet()
        return True

    def run(self) -> str:
        """Every aPad's loop to the mission's end, checkpointed from now on; the reason it ended
        (several: each reason once). `finish` once the front end has written the results."""
        if self._checkpoints is not None:
            clock = self.world.clock
            first_us = clock.now_us + seconds_to_us(self.checkpoint_period_s)
            if self._replaying and self._saved is not None and self._saved.time_us > clock.now_us:
                first_us = self._saved.time_us  # the replay stops where the checkpoint was, whatever its period
            self._task = clock.scheduler.every(self.checkpoint_period_s, self._checkpoint, "checkpoint", first_us)
        if self.swarm:
            processes = Processes(self.world.clock)
            for sysid in self.apad_ids:
                processes.spawn(f"apad{sysid}", functools.partial(self._run_loop, sysid))
            processes.run()
        else:
            self._run_loop(self.apad_ids[0], self.world.clock)
        if self._task is not None:
            self._task.active = False
        if self._replaying:
            raise CheckpointError("the mission ended before its replay reached the checkpoint: "
                                  "it was written by another version of vil or of the scenario")
        return self.outcome().end_reason

    def finish(self) -> None:
        """The mission ended and its results are written: nothing to resume, the checkpoint goes."""
        if self._checkpoints is not None:
            self._checkpoints.remove()
            self._checkpoints = None

    def close(self) -> None:
        """Keep the checkpoint (a mission that did not end can be resumed) and close its files."""
        if self._checkpoints is not None:
            self._checkpoints.close()

    def outcome(self) -> Outcome:
        return Outcome(dict(sorted(self.loops.items())), self.shares, self.apad_times, self.apad_record)

    def result(self, wall_s: float) -> RunResult:
        return collect_result(self.world, self.outcome(), wall_s)

    # --- inside ----------------------------------------------------------------------------------

    def _share_fleet(self) -> None:
        """The first sharing of the fleet among every aPad heard (a restored mission's own), and the
        watch that re-shares it."""
        world = self.world
        restored = self._saved if self.resuming else None
        self.shares = shares = restored.shares if restored is not None and restored.shares else FleetShares()
        self.watch = watch = SwarmWatch(
            world.link.registry, shares, world.frame, {a.system_id: a.battery_end_v for a in world.scenario.apads},
            world.events, world.clock, seed=world.scenario.seed, fleet_size=world.scenario.fleet.count)
        if restored is not None:
            watch.retired |= restored.retired
        if isinstance(world.clock, EventClock):  # a new share is news to a loop waiting on its own
            world.clock.hears(lambda: shares.version)
        watch.check(world.clock.now_us)
        watch.register(world.clock.now_us + seconds_to_us(1.0))

    def _run_loop(self, sysid: int, clock: Clock) -> EndReason:
        loop = self.world.mission_loop(self._controls.get(sysid), apad_id=sysid, shares=self.shares, clock=clock,
                                       status=self._statuses.get(sysid))
        loop.status.apad_time_us = self.apad_times[sysid]  # the same dict: a checkpoint of the status holds it
        self.loops[sysid] = loop
        if loop.status.end_reason is not None:  # restored: this aPad's loop had ended before the crash
            return loop.status.end_reason
        end = loop.run(resume=self.resuming)
        if end == EndReason.APAD_BATTERY and self.watch is not None:
            self.watch.retire(sysid)  # out for good: its share goes to the others now
        return end

    def _checkpoint(self, now_us: int) -> None:
        statuses = {sysid: loop.status for sysid, loop in self.loops.items()}
        if self._replaying:
            self._arrive(now_us, statuses)
            return
        assert self._checkpoints is not None
        retired = frozenset(self.watch.retired) if self.watch is not None else frozenset()
        checkpoint.save(self._checkpoints, checkpoint.capture(self.world, statuses, self.shares, retired, self._setup))

    def _arrive(self, now_us: int, statuses: dict[int, LoopStatus]) -> None:
        """A replay at a checkpoint instant: at the saved one, the same state or a `CheckpointError`;
        then the logs go on from there."""
        saved = self._saved
        assert saved is not None
        if now_us < saved.time_us:
            return
        if now_us > saved.time_us or checkpoint.fingerprint(self.world, statuses) != saved.fingerprint:
            raise CheckpointError("replayed to the checkpoint, the mission is not where it was: the checkpoint "
                                  "was written by another version of vil or of the scenario")
        self._replaying = False
        self.world.mute_logs(False)
        self.world.events.emit(self.world.clock.time(), "mission_resume", how="replayed to the checkpoint")
