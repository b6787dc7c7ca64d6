"""Headless mission runs: one scenario on a platform (lockstep or event), a `RunResult` and a run folder out.

The world on a virtual clock (`headless_world`), the mission's lifecycle in a `MissionSession`; the
run folder (`gcs.records.run_folder`) gets the logs as the mission runs, its checkpoint every 10 s
(lockstep: the event platform runs a mission in seconds and keeps none), and result.json and
traces.npz at the end.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

from gcs.mission import checkpoint
from gcs.mission.outcome import write_endpoints, write_outputs
from gcs.mission.platform import Platform
from gcs.mission.session import MissionSession
from gcs.mission.world import LinkOptions, World, headless_world
from gcs.records.run_folder import RunFolder
from gcs.results.run_result import RunResult
from gcs.scenario.reader import Scenario
from missiontime import us_to_s

ProgressFn = Callable[[float], None]  # receives mission time done, seconds
WorldFn = Callable[[World], None]  # reads the world when the mission has ended (`vil sweep`: the active counts)
PROGRESS_PERIOD_S = 10.0


def run_stem(scenario: Scenario) -> str:
    """What a run's folder is named after; `RunFolder.new` adds -runK so runs never share one."""
    return f"{scenario.name}-{scenario.mission.collect_strategy}-seed{scenario.seed}"


def run_mission(
    scenario: Scenario, out_dir: Path | None = None, progress: ProgressFn | None = None,
    options: LinkOptions | None = None,
    resume: bool = False, on_end: WorldFn | None = None, platform: Platform = Platform.LOCKSTEP,
) -> RunResult:
    """Run one mission (one aPad or several) on `platform` to its end; write its folder if `out_dir` is given.

    `options` route the aPad link through a fault proxy over UDP and/or sign it. With `out_dir` the
    run checkpoints itself there; `resume` continues from that checkpoint after a crash, by replaying
    the mission to it (`gcs.mission.session`): the results are those of a run never interrupted.
    """
    wall_start = time.perf_counter()
    folder = RunFolder(out_dir) if out_dir is not None else None
    keeps = folder is not None and platform is Platform.LOCKSTEP
    files = checkpoint.CheckpointFiles(folder.checkpoint) if keeps and folder is not None else None
    saved = None
    setup = checkpoint.setup_digest(scenario, options)
    if resume:
        if files is None or folder is None:
            raise checkpoint.CheckpointError("resuming needs the run's output folder")
        saved = files.read()
        checkpoint.check_setup(saved, setup)  # before anything is cut
        checkpoint.cut_logs(folder, saved)  # the stretch after it is simulated again
    world = headless_world(scenario, out_dir, options, append_logs=saved is not None, muted_logs=saved is not None,
                           platform=platform)
    if folder is not None:
        write_endpoints(world, folder)
    session = MissionSession(world, files, saved, replay=True, setup=setup,
                             checkpoint_period_s=checkpoint.LOCKSTEP_CHECKPOINT_PERIOD_S)
    try:
        if progress is not None:
            world.clock.scheduler.every(PROGRESS_PERIOD_S, lambda now_us: progress(us_to_s(now_us)), "progress",
                                        world.clock.now_us)
        session.start()
        session.run()
        if on_end is not None:
            on_end(world)
        result = session.result(time.perf_counter() - wall_start)
        if folder is not None:
            write_outputs(world, result, folder, session.apad_times, session.apad_record)
        session.finish()
        return result
    finally:
        session.close()
        world.close()
