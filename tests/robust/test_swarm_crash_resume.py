"""A swarm mission killed with SIGKILL at five points (two in `make test`), each time resumed: the same
mission as one never interrupted, byte for byte (result.json but its wall time, every .tlog and aPad
log), and every event once (events.jsonl is the uninterrupted run's plus one `mission_resume` per resume).

A chain, as a week at sea might go: the run is killed, the resumed run is killed later, and so on;
each resume replays the mission from its start with the logs muted to its last checkpoint
(`gcs.mission.session`). Real processes, real SIGKILL, real files.
"""

from __future__ import annotations

import itertools
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from gcs.mission.checkpoint import CheckpointError, load
from gcs.records.run_folder import RunFolder

pytestmark = [pytest.mark.sitl, pytest.mark.slow]

VIL = [sys.executable, "-m", "gcs.cli", "run"]
WALL_TIMEOUT_S = 120.0


def _run_killed_after(args: list[str], folder: RunFolder, after_s: float, resume: bool, err: Path) -> float:
    """Start `vil run ARGS` (resuming or not), SIGKILL it once its checkpoint is past `after_s`; the
    checkpoint's mission time then."""
    with err.open("a") as err_file:
        proc = subprocess.Popen([*VIL, *args, *(["--resume"] if resume else [])], stdout=subprocess.DEVNULL,
                                stderr=err_file)
    try:
        deadline = time.monotonic() + WALL_TIMEOUT_S
        while True:
            assert proc.poll() is None, err.read_text()
            assert time.monotonic() < deadline, f"no checkpoint past {after_s} s within {WALL_TIMEOUT_S} s"
            try:
                if folder.checkpoint.exists() and load(folder.checkpoint).time_us > after_s * 1e6:
                    break
            except CheckpointError:  # caught mid-write (the small file is replaced atomically; its side files grow)
                pass
            time.sleep(0.1)
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.wait(10)
    assert proc.returncode == -signal.SIGKILL
    return load(folder.checkpoint).time_us / 1e6


# Each: the scenario, and the mission times of the checkpoints after which the five kills fall (bay120's
# aPad 3 falls silent between two of them: the share is taken over, and the resumes replay that too).
CASES = {
    "pool12x2": (["pool12x2", "--duration", "20min"], (100, 200, 300, 400, 500)),  # time to spare after the last kill
    "bay120-fail-apad": (["bay120", "--duration", "8min", "--fail-apad", "3:130s"], (40, 100, 160, 220, 280)),
}
CI_KILLS = (1, 3)  # `make test` kills at two of the five points (bay120's on both sides of the aPad's silence)


@pytest.mark.parametrize("case", CASES)
def test_killed_at_two_points_and_resumed_a_swarm_mission_is_the_one_never_interrupted(
    tmp_path: Path, case: str
) -> None:
    scenario, kill_at_s = CASES[case]
    killed_and_resumed_is_whole(tmp_path, scenario, tuple(kill_at_s[k] for k in CI_KILLS))


@pytest.mark.long
@pytest.mark.parametrize("case", CASES)
def test_killed_at_five_points_and_resumed_a_swarm_mission_is_the_one_never_interrupted(
    tmp_path: Path, case: str
) -> None:
    scenario, kill_at_s = CASES[case]
    killed_and_resumed_is_whole(tmp_path, scenario, kill_at_s)


def killed_and_resumed_is_whole(tmp_path: Path, scenario: list[str], kill_at_s: tuple[int, ...]) -> None:
    whole_root, killed_root = tmp_path / "whole", tmp_path / "killed"
    done = subprocess.run([*VIL, *scenario, "--out", str(whole_root)], capture_output=True, text=True,
                          timeout=WALL_TIMEOUT_S)
    assert done.returncode == 0, done.stderr
    (whole_dir,) = [p for p in whole_root.iterdir() if p.name != "latest"]
    whole = RunFolder(whole_dir)
    killed = RunFolder(killed_root / whole_dir.name)
    args, err = [*scenario, "--out", str(killed_root)], tmp_path / "stderr.txt"

    kills = [_run_killed_after(args, killed, at_s, k > 0, err) for k, at_s in enumerate(kill_at_s)]
    assert all(a < b for a, b in itertools.pairwise(kills))  # distinct points
    done = subprocess.run([*VIL, *args, "--resume"], capture_output=True, text=True, timeout=WALL_TIMEOUT_S)
    assert done.returncode == 0, done.stderr

    a, b = (json.loads(f.result.read_text()) for f in (killed, whole))
    for r in (a, b):
        del r["wall_s"], r["out_dir"]
    assert a == b
    assert not killed.checkpoint.exists()
    apads = [row["sysid"] for row in b["apads"]]
    assert len(apads) > 1
    for path in (whole.gcs_tlog, *[p for p in whole.logs(apads) if p != whole.events]):
        assert (killed.path / path.name).read_bytes() == path.read_bytes(), path.name
    events = killed.events.read_text().splitlines()
    resumes = [line for line in events if json.loads(line)["event"] == "mission_resume"]
    assert [round(json.loads(line)["t_s"]) for line in resumes] == [round(t) for t in kills]
    assert [line for line in events if line not in resumes] == whole.events.read_text().splitlines()
    t_killed, t_whole = np.load(killed.traces), np.load(whole.traces)
    assert t_killed.files == t_whole.files
    for key in t_whole.files:
        np.testing.assert_array_equal(t_killed[key], t_whole[key])
