"""Run folders: a new one per run, `latest` at the last one started, the newest checkpoint found for a resume."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from gcs.records import rundirs
from gcs.records.replay import run_files


def test_every_run_gets_a_new_folder_after_the_highest_number_there(tmp_path: Path) -> None:
    first = rundirs.new_run_dir(tmp_path / "runs", "pool12-greedy-seed1")
    second = rundirs.new_run_dir(tmp_path / "runs", "pool12-greedy-seed1")
    other = rundirs.new_run_dir(tmp_path / "runs", "pool12-greedy-seed12")  # a prefix of no other stem
    assert [first.name, second.name, other.name] == ["pool12-greedy-seed1-run1", "pool12-greedy-seed1-run2",
                                                    "pool12-greedy-seed12-run1"]
    first.rmdir()  # deleting an old run never brings its name back for a newer one
    assert rundirs.new_run_dir(tmp_path / "runs", "pool12-greedy-seed1").name == "pool12-greedy-seed1-run3"


def test_a_folder_taken_meanwhile_is_skipped(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "s-run1").mkdir()
    monkeypatch.setattr(rundirs, "_numbers", lambda root, stem: {})  # as if another process took run1 after the scan
    assert rundirs.new_run_dir(tmp_path, "s").name == "s-run2"


def test_the_newest_folder_holding_a_checkpoint_is_the_one_to_resume(tmp_path: Path) -> None:
    for k in (1, 2, 3):
        (tmp_path / f"s-run{k}").mkdir()
    (tmp_path / "s-run2" / "checkpoint.pkl").write_bytes(b"")
    assert rundirs.newest_run_dir(tmp_path, "s") == tmp_path / "s-run3"
    assert rundirs.newest_run_dir(tmp_path, "s", holding="checkpoint.pkl") == tmp_path / "s-run2"
    assert rundirs.newest_run_dir(tmp_path, "t", holding="checkpoint.pkl") is None


def test_latest_points_at_the_last_run_as_a_symlink_or_else_a_text_file(tmp_path: Path,
                                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    a, b = (rundirs.new_run_dir(tmp_path, "s") for _ in range(2))
    (b / "gcs.tlog").write_bytes(b"")
    rundirs.point_latest(a)
    rundirs.point_latest(b)
    latest = tmp_path / rundirs.LATEST
    assert latest.is_symlink() and os.readlink(latest) == b.name
    assert run_files(latest).folder.resolve() == b.resolve()

    def no_symlinks(self: Path, target: str, target_is_directory: bool = False) -> None:
        raise OSError("symlinks not supported here")

    monkeypatch.setattr(Path, "symlink_to", no_symlinks)
    rundirs.point_latest(a)
    rundirs.point_latest(b)
    assert not latest.is_symlink() and latest.read_text().strip() == b.name
    assert run_files(latest).folder == b
    assert sorted(p.name for p in tmp_path.iterdir()) == ["latest", "s-run1", "s-run2"]  # no temp files left
