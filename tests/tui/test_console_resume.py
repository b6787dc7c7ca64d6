"""A resumed console, driven headless with Pilot: it shows the mission so far and goes on from the checkpoint.

The checkpoint is one a lockstep run left mid-mission (its later saves dropped, as a crash would);
the console then runs the same scenario on a PacedClock from the checkpoint's time.
"""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest
from tui_helpers import screen_text, wait_for

from gcs.console.app import LiveConsole
from gcs.console.runner import ConsoleConfig, ConsoleRunner, ResumePoint
from gcs.mission import checkpoint
from gcs.mission.checkpoint import CheckpointFiles
from gcs.mission.headless import run_mission
from gcs.mission.world import LOCKSTEP_EPOCH_US
from gcs.records.run_folder import CHECKPOINT, RunFolder
from gcs.scenario.reader import load_scenario
from missiontime import mm_ss
from mussel_sim.vocabulary import MusselState

pytestmark = [pytest.mark.tui, pytest.mark.sitl]

POOL12 = Path(__file__).resolve().parents[2] / "missions" / "pool12.toml"
SIZE = (150, 46)
CRASH_AT_S = 300.0  # pool12 charges its first four aMussels then


def test_a_resumed_console_shows_the_history_and_releases_the_docked_before_calling_up(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    real_save = checkpoint.save

    class Crash(Exception):
        """The mission stops at its first checkpoint past the crash, as a killed process would."""

    def save_until_the_crash(files: CheckpointFiles, ckpt: checkpoint.Checkpoint) -> None:
        if ckpt.time_us > CRASH_AT_S * 1e6:
            raise Crash
        real_save(files, ckpt)

    monkeypatch.setattr(checkpoint, "save", save_until_the_crash)
    scenario = load_scenario(POOL12)
    with pytest.raises(Crash):
        run_mission(scenario, tmp_path)
    monkeypatch.undo()
    files = CheckpointFiles(tmp_path / CHECKPOINT)
    saved = files.read()
    checkpoint.cut_logs(RunFolder(tmp_path), saved)
    docked = {int(i) for i, s in zip(saved.fleet_state.ids, saved.fleet_state.state, strict=True)
              if s == MusselState.DOCKED}
    assert docked and saved.time_us > (CRASH_AT_S - checkpoint.LOCKSTEP_CHECKPOINT_PERIOD_S) * 1e6

    runner = ConsoleRunner(ConsoleConfig(scenario, sitl="memory", speed=200.0, out_dir=tmp_path, start_paused=True,
                                         epoch_us=LOCKSTEP_EPOCH_US, resume=ResumePoint(files, saved)))
    app = LiveConsole(runner)

    def kinds() -> list[tuple[str, int]]:
        assert runner.world is not None
        return [(e.kind, int(e.fields.get("mussel", 0))) for e in list(runner.world.events.events)]

    async def drive() -> None:
        async with app.run_test(size=SIZE) as pilot:
            await wait_for(pilot, lambda: runner.snapshot is not None and "loop paused" in runner.snapshot.notice)
            snap = runner.snapshot
            assert snap is not None and snap.t_s >= saved.time_us / 1e6  # on from the checkpoint, not from 0
            # The mission before the crash, as the crashed console showed it.
            assert snap.log and all(line[:5] <= mm_ss(saved.time_us / 1e6) for line in snap.log)
            assert f"docked aMussel {saved.loop_statuses[1].dockings[-1][1]}" in "\n".join(snap.log)
            assert snap.strategy == saved.loop_statuses[1].strategy
            await wait_for(pilot, lambda: "docked aMussel" in screen_text(app))
            await pilot.press("p")
            await wait_for(pilot, lambda: runner.world is not None and any(k == "call_up" for k, _ in kinds()),
                           timeout_s=60)
            await pilot.press("Q")
            await wait_for(pilot, runner.finished.is_set, timeout_s=30)

    asyncio.run(drive())
    assert runner.error is None
    seen = kinds()
    # The mission's first event is its resumption; the operator's `p` (from the app's thread) is logged beside.
    assert next(k for k in seen if k[0] != "operator") == ("mission_resume", 0) and ("operator", 0) in seen
    for mussel in docked:  # released before anything is called up for it
        mine = [k for k, m in seen if m == mussel and k in ("call_up", "released")]
        assert mine[:1] == ["released"], (mussel, mine)
    assert not (tmp_path / CHECKPOINT).exists()  # the operator ended the mission: nothing to resume
