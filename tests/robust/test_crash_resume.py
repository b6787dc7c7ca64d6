"""kill -9 of a real `vil run` process mid-mission, then `vil run --resume`: the same mission completes."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from gcs.records.checkpoint import CHECKPOINT_NAME, load

pytestmark = [pytest.mark.sitl, pytest.mark.slow]

VIL = [sys.executable, "-m", "gcs.cli"]
ARGS = ["run", "pool12", "--strategy", "greedy", "--duration", "1h", "--jobs", "1"]


def test_sigkill_mid_mission_then_resume_completes_with_every_mussel_accounted_for(tmp_path: Path) -> None:
    out = tmp_path / "runs"
    run_dir = out / "pool12-greedy-seed1"
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
    assert not ckpt.exists()  # finished: nothing left to resume
    # The uptime record spans the whole mission, not only the part after the crash.
    traces = np.load(run_dir / "traces.npz")
    assert traces["step_time_us"][0] <= 1_000_000 and traces["step_time_us"][-1] >= 3_590_000_000


def test_resume_without_a_checkpoint_is_one_line_and_exit_2(tmp_path: Path) -> None:
    done = subprocess.run([*VIL, *ARGS, "--out", str(tmp_path), "--resume"], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "nothing to resume" in done.stderr
