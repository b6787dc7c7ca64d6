"""kill -9 of a real `vil run` process mid-mission, then `vil run --resume`: the same mission completes,
in the same folder, with every event and message logged once.

And in process: a resume from the incremental checkpoint files is exactly a resume from the whole
state the checkpoint was taken of (what pickling everything at once used to save); a resume cuts
what the crashed run logged after its last checkpoint; a corrupt checkpoint is one line, exit 2.
"""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from gcs.mission import checkpoint
from gcs.mission.checkpoint import load
from gcs.mission.headless import run_mission
from gcs.records.run_folder import CHECKPOINT, RunFolder
from gcs.scenario.reader import load_scenario
from mavlink_dialect import tlog

pytestmark = [pytest.mark.sitl, pytest.mark.slow]

VIL = [sys.executable, "-m", "gcs.cli"]
# Half an hour (the kill falls in its second third) is as long a mission as the kill and the resume need.
DURATION_S = 1800
KILL_AFTER_S = 600
ARGS = ["run", "pool12", "--strategy", "greedy", "--duration", f"{DURATION_S}s", "--jobs", "1"]


def test_sigkill_mid_mission_then_resume_completes_with_every_mussel_accounted_for(tmp_path: Path) -> None:
    out = tmp_path / "runs"
    run_dir = out / "pool12-greedy-seed1-run1"
    ckpt = run_dir / CHECKPOINT
    env = {**os.environ, "COLUMNS": "100"}
    err = tmp_path / "stderr.txt"
    with err.open("w") as err_file:
        proc = subprocess.Popen([*VIL, *ARGS, "--out", str(out)], stdout=subprocess.DEVNULL, stderr=err_file, env=env)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:  # wait until the mission is well under way
            if ckpt.exists() and load(ckpt).time_us > KILL_AFTER_S * 1_000_000:
                break
            assert proc.poll() is None, err.read_text()
            time.sleep(0.05)
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.wait(10)
    assert proc.returncode == -signal.SIGKILL
    killed_at_s = load(ckpt).time_us / 1e6
    assert KILL_AFTER_S < killed_at_s < DURATION_S
    assert not (run_dir / "result.json").exists()

    done = subprocess.run([*VIL, *ARGS, "--out", str(out), "--resume", "--json", str(tmp_path / "r.json")],
                          capture_output=True, text=True, timeout=120, env=env)
    assert done.returncode == 0, done.stderr
    r = json.loads((tmp_path / "r.json").read_text())
    assert r["end_reason"] == "mission time" and r["duration_s"] == DURATION_S
    assert len(r["whereabouts"]) == 12 and [w for w in r["whereabouts"] if w["where"] == "lost"] == []
    events = [json.loads(x) for x in (run_dir / "events.jsonl").read_text().splitlines()]
    kinds = [e["event"] for e in events]
    assert kinds[0] == "mission_start" and "mission_resume" in kinds and kinds[-1] == "mission_end"
    resume = kinds.index("mission_resume")
    assert events[resume]["t_s"] == pytest.approx(killed_at_s)
    # Each event once: what the killed run logged after its last checkpoint was cut, not repeated.
    assert all(e["t_s"] <= killed_at_s for e in events[:resume])
    times = [e["t_s"] for e in events]
    assert times == sorted(times)
    for log in ("gcs.tlog", "apad1.tlog"):
        stamps = [stamp for stamp, _ in tlog.frames(run_dir / log)]
        assert stamps == sorted(stamps), log
    assert sorted(p.name for p in out.iterdir()) == ["latest", "pool12-greedy-seed1-run1"]
    assert not ckpt.exists()  # finished: nothing left to resume
    assert not any(ckpt.with_suffix(x).exists() for x in (checkpoint.STEPS_SUFFIX, checkpoint.TRACES_SUFFIX))
    # The uptime record spans the whole mission, one step a second: the steps after the resume keep
    # the rhythm of those before it (no long first step, none lost).
    traces = np.load(run_dir / "traces.npz")
    assert np.array_equal(traces["step_time_us"], np.arange(1, DURATION_S + 1) * 1_000_000)


def test_resume_without_a_checkpoint_is_one_line_and_exit_2(tmp_path: Path) -> None:
    (tmp_path / "pool12-greedy-seed1-run1").mkdir()  # a run that finished: no checkpoint left
    done = subprocess.run([*VIL, *ARGS, "--out", str(tmp_path), "--resume"], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "nothing to resume" in done.stderr


@pytest.mark.parametrize("damage", ["garbage", "truncated", "side file cut", "other run"])
def test_a_corrupt_checkpoint_is_one_line_and_exit_2_before_anything_runs(tmp_path: Path, damage: str) -> None:
    folder = tmp_path / "pool12-greedy-seed1-run1"
    strategy = "cautious" if damage == "other run" else "greedy"
    scenario = load_scenario("pool12").with_overrides(strategy=strategy, duration_s=60.0)
    files = checkpoint.CheckpointFiles(folder / CHECKPOINT)
    real_remove = checkpoint.CheckpointFiles.remove
    checkpoint.CheckpointFiles.remove = checkpoint.CheckpointFiles.close  # type: ignore[method-assign]
    try:
        run_mission(scenario, folder)  # leaves its last checkpoint behind, as a crash would
    finally:
        checkpoint.CheckpointFiles.remove = real_remove  # type: ignore[method-assign]
    ckpt = folder / CHECKPOINT
    assert load(files).time_us > 0
    (folder / "result.json").unlink()
    if damage == "garbage":
        ckpt.write_bytes(b"\x80\x05garbage")
    elif damage == "truncated":
        ckpt.write_bytes(ckpt.read_bytes()[:200])
    elif damage == "side file cut":
        steps = ckpt.with_suffix(checkpoint.STEPS_SUFFIX)
        steps.write_bytes(steps.read_bytes()[:40])
    done = subprocess.run([*VIL, *ARGS, "--out", str(tmp_path), "--resume"], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
    assert done.stderr.count("\n") == 1 and str(folder / "checkpoint") in done.stderr, done.stderr
    assert not (folder / "result.json").exists()  # nothing ran


@pytest.mark.parametrize("crashed_period_s", [None, 10.0])
def test_a_resume_cuts_what_the_crashed_run_logged_after_its_last_checkpoint_and_logs_it_once(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, crashed_period_s: float | None
) -> None:
    """The crashed run logged a minute past its last checkpoint; the resumed one replays to the
    checkpoint with its logs muted and goes on: every log is the uninterrupted run's, byte for byte,
    but for the one `mission_resume` event, and so are result.json and traces.npz. `crashed_period_s`:
    the crashed run checkpointed on another period (an older vil's 10 s, off the resumed run's grid)."""
    if crashed_period_s is not None:
        monkeypatch.setattr(checkpoint, "LOCKSTEP_CHECKPOINT_PERIOD_S", crashed_period_s)
    scenario = load_scenario("pool12").with_overrides(strategy="greedy", duration_s=900.0)
    whole, crashed = tmp_path / "whole", tmp_path / "crashed"
    real_save, at = checkpoint.save, {}

    def save_and_crash(files: checkpoint.CheckpointFiles, ckpt: checkpoint.Checkpoint) -> None:
        real_save(files, ckpt)
        if ckpt.time_us >= 400_000_000 and not at:  # the last checkpoint the crashed run took
            at["t_s"], at["events_bytes"] = ckpt.time_us / 1e6, ckpt.events_bytes
            shutil.copytree(whole, crashed)
        elif at and "logs" not in at and ckpt.time_us >= at["t_s"] * 1e6 + 60e6:
            # The crash: a minute of logs past that checkpoint, its next checkpoints lost.
            at["logs"] = True
            for name in ("events.jsonl", "gcs.tlog", "apad1.tlog", "apad1.events.jsonl"):
                shutil.copy(whole / name, crashed / name)

    monkeypatch.setattr(checkpoint, "save", save_and_crash)
    run_mission(scenario, whole)
    monkeypatch.undo()  # the resumed run saves with vil's own functions and period
    if crashed_period_s is not None:
        assert round(at["t_s"]) % 60 != 0  # off the resumed run's grid of minutes
    before = (crashed / "events.jsonl").read_bytes()
    assert "logs" in at and len(before) > at["events_bytes"]  # events after the checkpoint were logged
    run_mission(scenario, crashed, resume=True)
    for name in ("gcs.tlog", "apad1.tlog", "apad1.events.jsonl"):
        assert (crashed / name).read_bytes() == (whole / name).read_bytes(), name
    after, uninterrupted = (crashed / "events.jsonl").read_bytes(), (whole / "events.jsonl").read_bytes()
    cut = at["events_bytes"]
    resume_line, rest = after[cut:].split(b"\n", 1)
    assert json.loads(resume_line)["event"] == "mission_resume"
    assert json.loads(resume_line)["t_s"] == pytest.approx(at["t_s"])
    assert after[:cut] + rest == uninterrupted
    a, b = (json.loads((d / "result.json").read_text()) for d in (crashed, whole))
    for r in (a, b):
        del r["wall_s"], r["out_dir"]
    assert a == b and a["end_reason"] == "mission time"
    t_resumed, t_whole = (np.load(d / "traces.npz") for d in (crashed, whole))
    for key in t_whole.files:
        np.testing.assert_array_equal(t_resumed[key], t_whole[key])
    assert not (crashed / CHECKPOINT).exists()


def test_cut_logs_cuts_every_log_to_its_length_at_the_checkpoint_and_refuses_a_shorter_one(tmp_path: Path) -> None:
    folder = RunFolder(tmp_path)
    kept = b'{"t_s":1.0,"event":"start"}\n{"t_s":9.5,"event":"command"}\n'
    folder.apad_events(1).write_bytes(kept + b'{"t_s":9.9,"event":"comm')  # the kill fell mid-line
    folder.gcs_tlog.write_bytes(b"x" * 100)
    saved = SimpleNamespace(log_sizes={folder.apad_events(1).name: len(kept), folder.gcs_tlog.name: 64})
    checkpoint.cut_logs(folder, saved)  # type: ignore[arg-type]  # only the log sizes count
    assert folder.apad_events(1).read_bytes() == kept and folder.gcs_tlog.read_bytes() == b"x" * 64
    longer = SimpleNamespace(log_sizes={folder.gcs_tlog.name: 65})
    with pytest.raises(checkpoint.CheckpointError, match="shorter than at the checkpoint"):
        checkpoint.cut_logs(folder, longer)  # type: ignore[arg-type]
    missing = SimpleNamespace(log_sizes={folder.apad_tlog(2).name: 1})
    with pytest.raises(checkpoint.CheckpointError, match="missing"):
        checkpoint.cut_logs(folder, missing)  # type: ignore[arg-type]


def test_a_replay_that_does_not_arrive_at_the_checkpoint_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A checkpoint whose fingerprint the replay cannot reproduce (another version or scenario) is a
    `CheckpointError`, and the logs past the cut are not written."""
    scenario = load_scenario("pool12").with_overrides(strategy="greedy", duration_s=120.0)
    monkeypatch.setattr(checkpoint.CheckpointFiles, "remove", checkpoint.CheckpointFiles.close)
    run_mission(scenario, tmp_path)  # leaves its last checkpoint behind, as a crash would
    monkeypatch.undo()
    files = checkpoint.CheckpointFiles(RunFolder(tmp_path).checkpoint)
    saved = files.read()
    files.close()
    tampered = dataclasses.replace(saved, fingerprint="0" * 64)
    monkeypatch.setattr(checkpoint.CheckpointFiles, "read", lambda self: tampered)
    with pytest.raises(checkpoint.CheckpointError, match="not where it was"):
        run_mission(scenario, tmp_path, resume=True)
    assert (tmp_path / "events.jsonl").stat().st_size == saved.events_bytes


def test_cut_logs_cuts_nothing_when_any_log_is_wrong_and_refuses_a_name_outside_the_folder(tmp_path: Path) -> None:
    folder = RunFolder(tmp_path)
    folder.gcs_tlog.write_bytes(b"x" * 100)
    folder.events.write_bytes(b"y" * 10)
    one_short = SimpleNamespace(log_sizes={folder.gcs_tlog.name: 50, folder.events.name: 11})
    with pytest.raises(checkpoint.CheckpointError, match="shorter"):
        checkpoint.cut_logs(folder, one_short)  # type: ignore[arg-type]
    assert folder.gcs_tlog.stat().st_size == 100  # checked before any was cut
    outside = SimpleNamespace(log_sizes={"../gcs.tlog": 1})
    with pytest.raises(checkpoint.CheckpointError, match="cannot have"):
        checkpoint.cut_logs(folder, outside)  # type: ignore[arg-type]
