"""kill -9 of a real `vil run` process mid-mission, then `vil run --resume`: the same mission completes,
in the same folder, with every event and message logged once.

And in process: a resume from the incremental checkpoint files is exactly a resume from the whole
state the checkpoint was taken of (what pickling everything at once used to save); a resume cuts
what the crashed run logged after its last checkpoint; a corrupt checkpoint is one line, exit 2.
"""

from __future__ import annotations

import json
import os
import pickle
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from gcs.mission.headless import run_mission
from gcs.mission.scenario import load_scenario
from gcs.records import checkpoint
from gcs.records.checkpoint import CHECKPOINT_NAME, load
from mavlink_dialect import tlog

pytestmark = [pytest.mark.sitl, pytest.mark.slow]

VIL = [sys.executable, "-m", "gcs.cli"]
ARGS = ["run", "pool12", "--strategy", "greedy", "--duration", "1h", "--jobs", "1"]


def test_sigkill_mid_mission_then_resume_completes_with_every_mussel_accounted_for(tmp_path: Path) -> None:
    out = tmp_path / "runs"
    run_dir = out / "pool12-greedy-seed1-run1"
    ckpt = run_dir / CHECKPOINT_NAME
    env = {**os.environ, "COLUMNS": "100"}
    err = tmp_path / "stderr.txt"
    with err.open("w") as err_file:
        proc = subprocess.Popen([*VIL, *ARGS, "--out", str(out)], stdout=subprocess.DEVNULL, stderr=err_file, env=env)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:  # wait until the mission is well under way
            if ckpt.exists() and load(ckpt).time_us > 1200 * 1_000_000:
                break
            assert proc.poll() is None, err.read_text()
            time.sleep(0.05)
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.wait(10)
    assert proc.returncode == -signal.SIGKILL
    killed_at_s = load(ckpt).time_us / 1e6
    assert 1200 < killed_at_s < 3600
    assert not (run_dir / "result.json").exists()

    done = subprocess.run([*VIL, *ARGS, "--out", str(out), "--resume", "--json", str(tmp_path / "r.json")],
                          capture_output=True, text=True, timeout=120, env=env)
    assert done.returncode == 0, done.stderr
    r = json.loads((tmp_path / "r.json").read_text())
    assert r["end_reason"] == "mission time" and r["duration_s"] == 3600
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
    assert np.array_equal(traces["step_time_us"], np.arange(1, 3601) * 1_000_000)


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
    files = checkpoint.CheckpointFiles(folder / CHECKPOINT_NAME)
    real_remove = checkpoint.CheckpointFiles.remove
    checkpoint.CheckpointFiles.remove = checkpoint.CheckpointFiles.close  # type: ignore[method-assign]
    try:
        run_mission(scenario, folder)  # leaves its last checkpoint behind, as a crash would
    finally:
        checkpoint.CheckpointFiles.remove = real_remove  # type: ignore[method-assign]
    ckpt = folder / CHECKPOINT_NAME
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


def test_a_resume_cuts_what_the_crashed_run_logged_after_its_last_checkpoint(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
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
    monkeypatch.setattr(checkpoint, "save", real_save)
    before = (crashed / "events.jsonl").read_bytes()
    assert "logs" in at and len(before) > at["events_bytes"]  # events after the checkpoint were logged
    apad_before = (crashed / "apad1.events.jsonl").read_text().splitlines()
    apad_kept = [line for line in apad_before if json.loads(line)["t_s"] < at["t_s"]]
    assert len(apad_kept) < len(apad_before)  # and the aPad logged commands after it too
    run_mission(scenario, crashed, resume=True)
    after = (crashed / "events.jsonl").read_bytes()
    assert after[: at["events_bytes"]] == before[: at["events_bytes"]]
    events = [json.loads(x) for x in after[at["events_bytes"]:].decode().splitlines()]
    assert events[0]["event"] == "mission_resume" and events[0]["t_s"] == pytest.approx(at["t_s"])
    times = [e["t_s"] for e in events]
    assert times == sorted(times) and events[-1]["event"] == "mission_end"
    for name in ("gcs.tlog", "apad1.tlog"):
        stamps = [stamp for stamp, _ in tlog.frames(crashed / name)]
        assert stamps == sorted(stamps), name
    # The aPad's own event log: cut by mission time, then continued.
    apad_after = (crashed / "apad1.events.jsonl").read_text().splitlines()
    assert apad_after[: len(apad_kept)] == apad_kept
    resumed = [json.loads(line) for line in apad_after[len(apad_kept):]]
    assert resumed[0]["event"] == "start" and resumed[0]["t_s"] == pytest.approx(at["t_s"])
    assert [e["t_s"] for e in resumed] == sorted(e["t_s"] for e in resumed)


def test_the_apads_event_log_is_cut_before_the_checkpoint_and_before_a_line_the_kill_cut_short(
    tmp_path: Path,
) -> None:
    log = tmp_path / "apad1.events.jsonl"
    kept = '{"t_s":1.0,"event":"start"}\n{"t_s":9.5,"event":"command"}\n'
    log.write_text(kept + '{"t_s":9.9,"event":"comm')  # the kill fell mid-line, before the checkpoint
    saved = SimpleNamespace(time_us=10_000_000, events_bytes=0)
    checkpoint.cut_logs(tmp_path, saved, 0)  # type: ignore[arg-type]  # only its time and events length count
    assert log.read_text() == kept
    log.write_text(kept + '{"t_s":10.0,"event":"command"}\n{"t_s":12.0,"event":"command"}\n')
    checkpoint.cut_logs(tmp_path, saved, 0)  # type: ignore[arg-type]
    assert log.read_text() == kept  # logged again by the resumed aPad


def test_resuming_from_the_checkpoint_files_is_resuming_from_the_whole_state_they_were_saved_of(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    scenario = load_scenario("pool12").with_overrides(strategy="greedy", duration_s=1800.0)
    whole, files_run, state_run = tmp_path / "whole", tmp_path / "files", tmp_path / "state"
    real_save, taken = checkpoint.save, {}

    def save_and_take(files: checkpoint.CheckpointFiles, ckpt: checkpoint.Checkpoint) -> None:
        real_save(files, ckpt)
        if ckpt.time_us >= 900_000_000 and not taken:  # mid-mission, after several charging moves
            taken["state"] = pickle.dumps(ckpt)  # all of it, the recorder's whole history included
            shutil.copytree(whole, files_run)
            shutil.copytree(whole, state_run)

    monkeypatch.setattr(checkpoint, "save", save_and_take)
    run_mission(scenario, whole)  # uninterrupted
    monkeypatch.setattr(checkpoint, "save", real_save)
    assert taken
    run_mission(scenario, files_run, resume=True)
    monkeypatch.setattr(checkpoint, "load", lambda files: pickle.loads(taken["state"]))
    run_mission(scenario, state_run, resume=True)

    a = json.loads((files_run / "result.json").read_text())
    b = json.loads((state_run / "result.json").read_text())
    for r in (a, b):
        del r["wall_s"], r["out_dir"]
    assert a == b and a["end_reason"] == "mission time"
    t_whole, t_files, t_state = (np.load(d / "traces.npz") for d in (whole, files_run, state_run))
    for key in t_files.files:
        np.testing.assert_array_equal(t_files[key], t_state[key])
    # The resumed record starts with what the uninterrupted run recorded up to the checkpoint.
    k = 900
    for key in ("step_time_us", "active_count", "battery_steps"):
        np.testing.assert_array_equal(t_files[key][:k], t_whole[key][:k])
    np.testing.assert_array_equal(t_files["battery"][:k], t_whole["battery"][:k])
