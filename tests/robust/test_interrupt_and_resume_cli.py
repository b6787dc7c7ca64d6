"""The first hour with `vil run` (issue 23): Ctrl-C is an ordinary way to stop (one line: what was
kept, the exact command to go on; exit 130), a resume says where it resumed from, `--resume` with
other flags points at the run that can be resumed and how, the summary names the folder it made,
and `vil --version` answers. Real processes, real signals."""

from __future__ import annotations

import importlib.metadata
import os
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from testkit import ctrl_c_after_checkpoint, sigint_as_in_a_terminal

from gcs.records.run_folder import RunFolder

pytestmark = [pytest.mark.sitl, pytest.mark.slow]

VIL = [sys.executable, "-m", "gcs.cli"]
ROOT = Path(__file__).resolve().parents[2]
WALL_TIMEOUT_S = 120.0


def _vil(cwd: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*VIL, *args], cwd=cwd, capture_output=True, text=True, timeout=WALL_TIMEOUT_S,
                          env={**os.environ, "PYTHONPATH": str(ROOT), "COLUMNS": "100"})


def test_ctrl_c_of_vil_run_is_one_line_with_the_command_that_resumes_it(tmp_path: Path) -> None:
    # 3 h: the Ctrl-C comes at the first checkpoint past 300 s, and the run must still be going when it lands,
    # on an idle machine too (40 minutes left it about a second: the margin two siblings lost, d1f6f01).
    args = ["run", "pool12", "--strategy", "greedy", "--duration", "3h", "--out", "out"]
    folder = RunFolder(tmp_path / "out" / "pool12-greedy-seed1-run1")
    code, err = ctrl_c_after_checkpoint([*VIL, *args], tmp_path, {**os.environ, "PYTHONPATH": str(ROOT)},
                                        folder.checkpoint, 300.0, WALL_TIMEOUT_S)  # well into the mission
    assert code == 130, err
    assert "Traceback" not in err and err.count("\n") == 1, err
    assert f"checkpoint kept in {Path('out') / folder.path.name}" in err
    command = err.split("resume with: ")[1].strip()
    assert command == shlex.join(["vil", *args, "--resume"])

    done = _vil(tmp_path, *shlex.split(command)[1:])  # the very command it printed
    assert done.returncode == 0, done.stderr
    saved_at = err.split("(mission time ")[1].split(")")[0]
    assert f"resuming {Path('out') / folder.path.name} from its checkpoint at {saved_at}" in done.stderr
    assert f"in {Path('out') / folder.path.name}/" in " ".join(done.stdout.split())  # the summary names it
    assert folder.result.exists() and not folder.checkpoint.exists()


def test_resume_with_other_flags_names_the_run_that_can_be_resumed_and_how(tmp_path: Path) -> None:
    folder = RunFolder(tmp_path / "out" / "pool12-greedy-seed1-run1")
    folder.path.mkdir(parents=True)
    folder.checkpoint.write_bytes(b"")  # a run left mid-mission (its content is not read here)
    folder.command.write_text("vil run pool12 --strategy greedy --duration 2h --out out\n")
    done = _vil(tmp_path, "run", "pool12", "--out", "out", "--resume")
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert "nothing to resume" in done.stderr and "pool12-cautious-seed1" in done.stderr
    assert (f"{Path('out') / folder.path.name} holds one: resume it with: "
            "vil run pool12 --strategy greedy --duration 2h --out out --resume") in done.stderr


def test_vil_version_names_the_installed_version(tmp_path: Path) -> None:
    done = _vil(tmp_path, "--version")
    assert done.returncode == 0 and done.stdout.strip() == f"vil {importlib.metadata.version('vil')}"


def test_ctrl_c_of_several_runs_to_the_process_group_then_the_printed_command_finishes_them(tmp_path: Path) -> None:
    """Ctrl-C in a terminal reaches every process of the job (the parallel runs' workers too): one
    line; the printed command keeps the run that had finished, resumes the one that kept a
    checkpoint and runs the others."""
    # Table II: four runs, one at a time. Missions long enough (a second or so each) that the run caught with a
    # checkpoint is still running when the signal lands, on a loaded machine too (10-minute ones took a
    # quarter of a second once the fleet reported by exception, and the Ctrl-C could land on the next run).
    args = ["run", "--duration", "40min", "--out", "out", "--jobs", "1"]
    with sigint_as_in_a_terminal():
        proc = subprocess.Popen([*VIL, *args], cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                text=True, env={**os.environ, "PYTHONPATH": str(ROOT)}, start_new_session=True)
    out = tmp_path / "out"
    try:
        deadline = time.monotonic() + WALL_TIMEOUT_S
        def caught() -> bool:  # a run finished, and another holds a checkpoint: not the finished one's, which
            finished = {p.parent for p in out.glob("*/result.json")}  # it keeps a moment after its result
            return bool(finished) and any(p.parent not in finished for p in out.glob("*/checkpoint.pkl"))

        while not caught():
            assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
            time.sleep(0.05)
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=WALL_TIMEOUT_S)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and err.count("\n") == 1 and "checkpoint kept in" in err, err
    kept = {p.parent: p.read_text() for p in out.glob("*/result.json")}  # one, or more if the signal came late
    assert kept
    command = err.split("resume with: ")[1].strip()
    assert command == shlex.join(["vil", *args, "--resume"])
    done = _vil(tmp_path, *shlex.split(command)[1:])
    assert done.returncode == 0, done.stderr
    said = " ".join(done.stderr.split())
    assert all(f"had finished in out/{folder.name}/" in said for folder in kept), done.stderr
    assert said.count("had finished") == len(kept) and said.count("resuming ") <= 1, done.stderr
    assert all(folder.joinpath("result.json").read_text() == text for folder, text in kept.items())  # not run again
    summary = " ".join(done.stdout.split())
    assert summary.count("-seed1-run") == 4 and all(f"{folder.name}/" in summary for folder in kept)
    assert not any(list(out.glob(f"{folder.name.removesuffix('-run1')}-run2")) for folder in kept)  # none made again
