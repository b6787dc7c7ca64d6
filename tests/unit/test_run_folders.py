"""Run folders: a new one per run, `latest` at the last one started, the newest checkpoint found for a
resume, and every file a run leaves named by `RunFolder`, the one way writers and readers find them."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from gcs.records import run_folder
from gcs.records.playback import run_files
from gcs.records.run_folder import RunFolder


def test_every_run_gets_a_new_folder_after_the_highest_number_there(tmp_path: Path) -> None:
    first = RunFolder.new(tmp_path / "runs", "pool12-greedy-seed1").path
    second = RunFolder.new(tmp_path / "runs", "pool12-greedy-seed1").path
    other = RunFolder.new(tmp_path / "runs", "pool12-greedy-seed12").path  # a prefix of no other stem
    assert [first.name, second.name, other.name] == ["pool12-greedy-seed1-run1", "pool12-greedy-seed1-run2",
                                                    "pool12-greedy-seed12-run1"]
    first.rmdir()  # deleting an old run never brings its name back for a newer one
    assert RunFolder.new(tmp_path / "runs", "pool12-greedy-seed1").path.name == "pool12-greedy-seed1-run3"


def test_a_folder_taken_meanwhile_is_skipped(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "s-run1").mkdir()
    monkeypatch.setattr(run_folder, "_numbers", lambda root, stem: {})  # another process took run1 after the scan
    assert RunFolder.new(tmp_path, "s").path.name == "s-run2"


def test_the_newest_folder_holding_a_checkpoint_is_the_one_to_resume(tmp_path: Path) -> None:
    for k in (1, 2, 3):
        (tmp_path / f"s-run{k}").mkdir()
    RunFolder(tmp_path / "s-run2").checkpoint.write_bytes(b"")
    assert RunFolder.newest_resumable(tmp_path, "s") == RunFolder(tmp_path / "s-run2")
    assert RunFolder.newest_resumable(tmp_path, "t") is None


def test_latest_points_at_the_last_run_as_a_symlink_or_else_a_text_file(tmp_path: Path,
                                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    a, b = (RunFolder.new(tmp_path, "s") for _ in range(2))
    b.gcs_tlog.write_bytes(b"")
    a.point_latest()
    b.point_latest()
    latest = tmp_path / run_folder.LATEST
    assert latest.is_symlink() and os.readlink(latest) == b.path.name
    assert run_files(latest).folder.resolve() == b.path.resolve()

    def no_symlinks(self: Path, target: str, target_is_directory: bool = False) -> None:
        raise OSError("symlinks not supported here")

    monkeypatch.setattr(Path, "symlink_to", no_symlinks)
    a.point_latest()
    b.point_latest()
    assert not latest.is_symlink() and latest.read_text().strip() == b.path.name
    assert run_files(latest).folder == b.path
    assert sorted(p.name for p in tmp_path.iterdir()) == ["latest", "s-run1", "s-run2"]  # no temp files left


def test_a_run_leaves_only_files_its_run_folder_names(tmp_path: Path) -> None:
    """Every file a real two-aPad mission writes is one `RunFolder` names (no room invents a name)."""
    from gcs.mission.headless import run_mission
    from gcs.scenario.reader import load_scenario

    run_mission(load_scenario("pool12x2").with_overrides(duration_s=60.0), tmp_path)
    folder = RunFolder(tmp_path)
    named = {folder.gcs_tlog, folder.events, folder.result, folder.traces, folder.endpoints,
             *folder.logs([1, 2])}
    assert set(tmp_path.iterdir()) == named
    assert folder.apad_tlog(2).name == "apad2.tlog" and folder.apad_events(2).name == "apad2.events.jsonl"
