"""Where each run of a start goes: a new folder keeping the command that made it, or (resuming) the
newest folder of the same run holding a usable checkpoint of it (`gcs.mission.start` asks).

Resuming several runs at once (a Ctrl-C stops them where they are), one that had finished keeps its
result, one with no checkpoint runs from its start in a new folder, and each says so; resuming one
run that has no checkpoint is an error naming what could be resumed instead, and how.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from gcs.mission import checkpoint
from gcs.mission.checkpoint import CheckpointError
from gcs.mission.headless import run_stem
from gcs.records.run_folder import CHECKPOINT, RunFolder
from gcs.results.run_result import RunResult
from gcs.scenario.reader import Scenario


@dataclass(frozen=True)
class Placement:
    """Where a run goes."""

    out_dir: Path  # its own folder: new, the one it resumes, or (`finished`) where it ended before
    resume_from_s: float | None = None  # resuming: the mission time of its checkpoint
    finished: RunResult | None = None  # resuming several: this one had ended, its result is kept


def place(runs: Sequence[tuple[Scenario, Path, bool, str]], command: str,
          say: Callable[[str], None]) -> list[Placement]:
    """The folder of each run (scenario, root of its folders, whether to resume it, the digest of how it
    is started: `checkpoint.setup_digest`); see the module's docstring. `command` is what a new folder
    keeps (the command line without --resume: what resumes it). `CheckpointError` (one line) if a run to
    resume has none, one of another run, or one started with other settings."""
    found = [RunFolder.newest_resumable(root, run_stem(s)) if resume else None for s, root, resume, _ in runs]
    some = len(runs) > 1 and any(found)  # several runs, some of them stopped mid-mission: resume those
    placed = []
    for (scenario, root, resume, setup), folder in zip(runs, found, strict=True):
        stem = run_stem(scenario)
        if resume and folder is None and some:
            done = _finished(root, stem, command)
            if done is not None:
                say(f"{stem} had finished in {done.out_dir}/: its result is kept")
                placed.append(Placement(Path(done.out_dir), finished=done))
                continue
            say(f"no checkpoint of {stem} under {root}: it runs from the start")
        elif resume:
            if folder is None:
                raise CheckpointError(f"nothing to resume: no {CHECKPOINT} in any {root / stem}-runK/"
                                      + _resumable_hint(root))
            saved = checkpoint.load(folder.checkpoint)  # a corrupt one is refused here, not mid-run
            key = checkpoint.scenario_key(scenario)
            if saved.run_key != key:
                raise CheckpointError(f"{folder.checkpoint} is of run {saved.run_key}, not {key}")
            checkpoint.check_setup(saved, setup)  # here, before anything runs: not a traceback mid-start
            placed.append(Placement(folder.path, resume_from_s=saved.time_us / 1e6))
            continue
        made = RunFolder.new(root, stem)
        made.command.write_text(command + "\n", encoding="utf-8")
        placed.append(Placement(made.path))
    return placed


def _finished(root: Path, stem: str, command: str) -> RunResult | None:
    """The result of the newest run of `stem` if the same command made it and it ended (a result, no
    checkpoint): the run of the interrupted batch that finished before the Ctrl-C."""
    folder = RunFolder.newest(root, stem)
    if folder is None or folder.checkpoint.exists() or not folder.result.exists() or not folder.command.exists():
        return None
    if folder.command.read_text(encoding="utf-8").strip() != command:
        return None
    try:
        return RunResult.from_json(json.loads(folder.result.read_text(encoding="utf-8")))
    except (OSError, ValueError, TypeError, KeyError):  # unreadable or of another version: run it again
        return None


def _resumable_hint(root: Path) -> str:
    """What could be resumed under `root` instead, and how (the run's own command: every flag counts)."""
    others = RunFolder.resumable(root)
    if not others:
        return ""
    newest = others[0]
    how = newest.resume_command()
    more = f" (and {len(others) - 1} more)" if len(others) > 1 else ""
    return (f"; {newest.path} holds one{more}: " + (f"resume it with: {how}" if how else
            "resume it with the scenario and flags it was started with, and --resume"))
