"""The mission session every front end drives (`gcs.mission.session`): what it checkpoints, when,
and what a resume from a restored checkpoint (the console's way) does with several aPads."""

from __future__ import annotations

import dataclasses
import json
import threading
from pathlib import Path

import pytest
from testkit import restored_session

from gcs.console.runner import ConsoleConfig, ConsoleRunner
from gcs.loop.control import EndReason
from gcs.mission import checkpoint
from gcs.mission.headless import run_mission
from gcs.records.run_folder import RunFolder
from gcs.scenario.reader import load_scenario

pytestmark = pytest.mark.sitl


def _left_checkpoint(folder: Path, scenario_name: str, duration_s: float, monkeypatch: pytest.MonkeyPatch) -> None:
    """A short headless run that leaves its last checkpoint behind, as a crash would."""
    monkeypatch.setattr(checkpoint.CheckpointFiles, "remove", checkpoint.CheckpointFiles.close)
    run_mission(load_scenario(scenario_name).with_overrides(duration_s=duration_s), folder)
    monkeypatch.undo()
    assert RunFolder(folder).checkpoint.exists()


def test_a_restored_swarm_does_not_restart_a_loop_that_had_ended(tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    """aPad 2's loop had ended (its battery) before the crash: restored, it stays ended, no
    `mission_resume` and no second `mission_end` for it; aPad 1 goes on and stays retired-aware."""
    scenario = load_scenario("pool12x2").with_overrides(duration_s=120.0)
    _left_checkpoint(tmp_path, "pool12x2", 120.0, monkeypatch)
    files = checkpoint.CheckpointFiles(RunFolder(tmp_path).checkpoint)
    saved = files.read()
    statuses = dict(saved.loop_statuses)
    statuses[2] = dataclasses.replace(statuses[2], end_reason=EndReason.APAD_BATTERY)
    saved = dataclasses.replace(saved, loop_statuses=statuses, retired=frozenset({2}))
    session = restored_session(scenario, tmp_path, saved)
    try:
        assert session.start()
        assert session.watch is not None and session.watch.retired == {2}
        session.run()
        session.finish()
    finally:
        session.close()
        session.world.close()
    events = [json.loads(line) for line in RunFolder(tmp_path).events.read_text().splitlines()]
    after = events[len(RunFolder(tmp_path).events.read_bytes()[: saved.events_bytes].splitlines()):]
    assert [e["apad"] for e in after if e["event"] == "mission_resume"] == [1]
    assert [e["apad"] for e in after if e["event"] == "mission_end"] == [1]
    assert session.outcome().loops[2].status.end_reason == EndReason.APAD_BATTERY
    assert not RunFolder(tmp_path).checkpoint.exists()


def test_a_checkpoint_of_other_settings_is_refused_before_anything_is_cut(tmp_path: Path,
                                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    _left_checkpoint(tmp_path, "pool12", 60.0, monkeypatch)
    events = RunFolder(tmp_path).events.read_bytes()
    other = load_scenario("pool12").with_overrides(duration_s=90.0)
    with pytest.raises(checkpoint.CheckpointError, match="other settings"):
        run_mission(other, tmp_path, resume=True)
    assert RunFolder(tmp_path).events.read_bytes() == events


def test_quitting_a_console_before_its_loops_start_leaves_no_checkpoint(tmp_path: Path) -> None:
    """Checkpoints start with the loops: a console quit while paused at the start has nothing to
    resume (it would otherwise resume a mission that never began)."""
    scenario = load_scenario("pool12")
    config = ConsoleConfig(scenario, sitl="memory", speed=50.0, out_dir=tmp_path, start_paused=True)
    runner = ConsoleRunner(config)
    thread = threading.Thread(target=runner.run, daemon=True)
    thread.start()
    try:
        for _ in range(400):  # until the console waits for p, past a checkpoint period of mission time
            snap = runner.snapshot
            if snap is not None and snap.t_s > checkpoint.CHECKPOINT_PERIOD_S + 1.0:
                break
            threading.Event().wait(0.05)
        else:
            pytest.fail("the paused console never ran past a checkpoint period")
        assert not runner.mission_running()
    finally:
        runner.request_quit(now=True)
        thread.join(30)
    assert not thread.is_alive() and runner.error is None
    assert not RunFolder(tmp_path).checkpoint.exists()
