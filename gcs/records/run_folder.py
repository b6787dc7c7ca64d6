"""A run's folder: the one place that names every file a run leaves, for every writer and reader.

    gcs.tlog             the GCS's MAVLink log (every frame it sent and heard)
    events.jsonl         the mission's event log
    apadN.tlog           aPad N's own MAVLink log and event log (named by the aPad: `apad_sitl.logs`)
    apadN.events.jsonl
    result.json          the run's figures (`gcs.results.run_result`)
    traces.npz           active count and battery traces per step, where the time went
    endpoints.json       the UDP ports a run over real sockets opened
    console.json         a console run's scenario and the Unix time of its mission time 0
    command.txt          the `vil` command line (or `vil.run` call) that started the run: what resumes it
    checkpoint.pkl       the checkpoint of a mission under way (+ .steps, .traces side files)
    report/              what `vil report` writes

New folders: `runs/SCENARIO-STRATEGY-seedN-runK/` (K one past the highest there, so deleting old
folders never brings a name back for a newer run), claimed with an exclusive `mkdir` so two `vil`
processes started at once get different ones. `runs/latest` is a relative symlink to the last
folder started, or, where symlinks cannot be made, a text file holding its name (`RunFolder.at`
follows either).
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

from apad_sitl import logs as apad_logs

LATEST = "latest"
GCS_TLOG = "gcs.tlog"
EVENTS = "events.jsonl"
RESULT = "result.json"
TRACES = "traces.npz"
ENDPOINTS = "endpoints.json"
CONSOLE = "console.json"
COMMAND = "command.txt"
CHECKPOINT = "checkpoint.pkl"
REPORT = "report"


@dataclass(frozen=True)
class RunFolder:
    """The files of one run, by what they are."""

    path: Path

    @classmethod
    def at(cls, path: str | Path) -> RunFolder:
        """The run folder at `path`, `latest` followed to the folder it names (a symlink or a text
        file), so what reads the run shows its own name."""
        p = Path(path)
        if p.name == LATEST and p.is_symlink():
            p = p.parent / os.readlink(p)  # relative as point_latest makes it, or absolute
        elif p.name == LATEST and p.is_file():
            name = p.read_text(encoding="utf-8").strip()
            if name and "/" not in name:
                p = p.parent / name
        return cls(p)

    @classmethod
    def new(cls, root: Path, stem: str) -> RunFolder:
        """Create `root/STEM-runK` with K one past the highest there."""
        root.mkdir(parents=True, exist_ok=True)
        k = max(_numbers(root, stem), default=0) + 1
        while True:
            path = root / f"{stem}-run{k}"
            try:
                path.mkdir()
                return cls(path)
            except FileExistsError:  # another process took it first
                k += 1

    @classmethod
    def newest_resumable(cls, root: Path, stem: str) -> RunFolder | None:
        """The highest-numbered `root/STEM-runK` holding a checkpoint; None if there is none."""
        for _, path in sorted(_numbers(root, stem).items(), reverse=True):
            if (path / CHECKPOINT).exists():
                return cls(path)
        return None

    @classmethod
    def newest(cls, root: Path, stem: str) -> RunFolder | None:
        """The highest-numbered `root/STEM-runK`; None if there is none."""
        numbers = _numbers(root, stem)
        return cls(numbers[max(numbers)]) if numbers else None

    @classmethod
    def resumable(cls, root: Path) -> list[RunFolder]:
        """Every run folder under `root` holding a checkpoint, the last modified first."""
        found = [p for p in root.glob(f"*/{CHECKPOINT}") if p.parent.name != LATEST] if root.is_dir() else []
        return [cls(p.parent) for p in sorted(found, key=lambda p: p.stat().st_mtime, reverse=True)]

    def point_latest(self) -> None:
        """Make `latest` beside this folder point at it (replaced atomically; best effort, never fatal)."""
        link = self.path.parent / LATEST
        tmp = self.path.parent / f".{LATEST}-{os.getpid()}"
        try:
            tmp.unlink(missing_ok=True)
            try:
                tmp.symlink_to(self.path.name, target_is_directory=True)
            except OSError:  # no symlinks here (some file systems, Windows without rights): a text file
                tmp.write_text(self.path.name + "\n")
            os.replace(tmp, link)
        except OSError:
            tmp.unlink(missing_ok=True)  # e.g. `latest` is a real folder someone made: leave it alone

    # --- the files -------------------------------------------------------------------------------

    @property
    def gcs_tlog(self) -> Path:
        return self.path / GCS_TLOG

    @property
    def events(self) -> Path:
        return self.path / EVENTS

    @property
    def result(self) -> Path:
        return self.path / RESULT

    @property
    def traces(self) -> Path:
        return self.path / TRACES

    @property
    def endpoints(self) -> Path:
        return self.path / ENDPOINTS

    @property
    def console(self) -> Path:
        return self.path / CONSOLE

    @property
    def checkpoint(self) -> Path:
        return self.path / CHECKPOINT

    @property
    def command(self) -> Path:
        return self.path / COMMAND

    def resume_command(self) -> str | None:
        """The command that resumes this run (its own command line and --resume; a `vil.run(...)` call
        with resume=True), if it kept one."""
        try:
            line = self.command.read_text(encoding="utf-8").strip()
        except OSError:
            return None
        if line.startswith("#"):  # kept to be read, not run (a scenario changed in Python)
            return None
        if line.startswith("vil.run(") and line.endswith(")"):
            return line if "resume=True" in line else f"{line[:-1]}, resume=True)"
        return line if "--resume" in line.split() else f"{line} --resume" if line else None

    @property
    def report(self) -> Path:
        return self.path / REPORT

    def apad_tlog(self, system_id: int) -> Path:
        return apad_logs.tlog_path(self.path, system_id)

    def apad_events(self, system_id: int) -> Path:
        return apad_logs.events_path(self.path, system_id)

    def logs(self, apad_ids: tuple[int, ...] | list[int]) -> list[Path]:
        """Every log a mission appends to as it runs, the aPads' included: the files a checkpoint's
        `log_sizes` name (the writers report their sizes: `World.log_sizes`)."""
        out = [self.gcs_tlog, self.events]
        for sysid in apad_ids:
            out += [self.apad_tlog(sysid), self.apad_events(sysid)]
        return out


def _numbers(root: Path, stem: str) -> dict[int, Path]:
    pattern = re.compile(rf"{re.escape(stem)}-run(\d+)")
    found: dict[int, Path] = {}
    if root.is_dir():
        for child in root.iterdir():
            match = pattern.fullmatch(child.name)
            if match and child.is_dir():
                found[int(match.group(1))] = child
    return found
