"""Run folders: a new one per run, never reused, and `latest` pointing at the last one started.

A run of scenario pool12, strategy greedy, seed 1 under `runs/` leaves `runs/pool12-greedy-seed1-run1/`,
the next one `...-run2/`, and so on (the number after the highest there, so deleting old folders
never brings a name back for a newer run). Folders are claimed with an exclusive `mkdir`, so two
`vil` processes started at once still get different ones. `runs/latest` is a relative symlink to
the last folder started, or, where symlinks cannot be made, a text file holding its name
(`resolve` follows either).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

LATEST = "latest"


def _numbers(root: Path, stem: str) -> dict[int, Path]:
    pattern = re.compile(rf"{re.escape(stem)}-run(\d+)")
    found: dict[int, Path] = {}
    if root.is_dir():
        for child in root.iterdir():
            match = pattern.fullmatch(child.name)
            if match and child.is_dir():
                found[int(match.group(1))] = child
    return found


def new_run_dir(root: Path, stem: str) -> Path:
    """Create and return `root/STEM-runN` with N one past the highest there."""
    root.mkdir(parents=True, exist_ok=True)
    k = max(_numbers(root, stem), default=0) + 1
    while True:
        path = root / f"{stem}-run{k}"
        try:
            path.mkdir()
            return path
        except FileExistsError:  # another process took it first
            k += 1


def newest_run_dir(root: Path, stem: str, holding: str | None = None) -> Path | None:
    """The highest-numbered `root/STEM-runN` (holding the file `holding`, if given); None if there is none."""
    for _, path in sorted(_numbers(root, stem).items(), reverse=True):
        if holding is None or (path / holding).exists():
            return path
    return None


def point_latest(run: Path) -> None:
    """Make `latest` beside `run` point at it (replaced atomically; best effort, never fatal)."""
    link = run.parent / LATEST
    tmp = run.parent / f".{LATEST}-{os.getpid()}"
    try:
        tmp.unlink(missing_ok=True)
        try:
            tmp.symlink_to(run.name, target_is_directory=True)
        except OSError:  # no symlinks here (some file systems, Windows without rights): a text file
            tmp.write_text(run.name + "\n")
        os.replace(tmp, link)
    except OSError:
        tmp.unlink(missing_ok=True)  # e.g. `latest` is a real folder someone made: leave it alone


def resolve(path: Path) -> Path:
    """`path`, or the run folder it names if it is a `latest` text file."""
    if path.name == LATEST and path.is_file() and not path.is_symlink():
        name = path.read_text(encoding="utf-8").strip()
        if name and "/" not in name:
            return path.parent / name
    return path
