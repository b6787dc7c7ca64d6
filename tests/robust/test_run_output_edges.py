"""What `vil run` prints at its edges (issue 39, the first hour): a reader that stops reading is not
an error, --seed beside --seeds is refused, long missions read as hours and days (never 172:00), and
the paper's Table II row stands only beside a run made as the paper's (40 minutes at theta 30)."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest
from rich.console import Console
from testkit import ctrl_c_after_checkpoint

from gcs.cli.tables import results_table
from gcs.records.run_folder import RunFolder
from gcs.results.run_result import RunResult
from missiontime.durations import hms

ROOT = Path(__file__).resolve().parents[2]
VIL = [sys.executable, "-m", "gcs.cli", "run"]
WALL_TIMEOUT_S = 120.0
ENV = {**{k: v for k, v in os.environ.items() if k != "COLUMNS"}, "PYTHONPATH": str(ROOT)}


@pytest.mark.sitl
def test_a_reader_that_stopped_reading_is_not_an_error(tmp_path: Path) -> None:
    """`vil run | head -3` with head gone before the tables: exit 0, no word on stderr, the JSON kept."""
    read, write = os.pipe()
    os.close(read)  # the reader has stopped before the first line: every write to the pipe fails
    try:
        done = subprocess.run([*VIL, "pool12", "--duration", "2min", "--out", "out", "--json", "r.json"], cwd=tmp_path,
                              stdout=write, stderr=subprocess.PIPE, text=True, timeout=WALL_TIMEOUT_S, env=ENV)
    finally:
        os.close(write)
    assert done.returncode == 0 and done.stderr == "", done.stderr
    assert json.loads((tmp_path / "r.json").read_text())["duration_s"] == 120.0


def test_seed_beside_seeds_is_refused_in_one_line(tmp_path: Path) -> None:
    done = subprocess.run([*VIL, "pool12", "--seeds", "3", "--seed", "2"], cwd=tmp_path, capture_output=True,
                          text=True, timeout=WALL_TIMEOUT_S, env=ENV)
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert "argument --seed: not allowed with argument --seeds" in done.stderr
    assert not (tmp_path / "runs").exists()


@pytest.mark.parametrize("t_s, text", [
    (0, "00:00"), (750.4, "12:30"), (3599, "59:59"), (3600, "1:00:00"), (172 * 60, "2:52:00"),
    (86399, "23:59:59"), (8 * 86400, "8 d 0 h"), (90 * 86400 - 1, "89 d 23 h"),
])
def test_mission_time_reads_as_minutes_hours_or_days(t_s: float, text: str) -> None:
    assert hms(t_s) == text


def _result(duration_s: float, theta: float) -> RunResult:
    return RunResult(scenario="pool12", strategy="greedy", seed=1, theta=theta, duration_s=duration_s,
                     uptime={"avg": 70.0, "max": 80.0, "min": 60.0}, cost_m=200.0, active_avg=9.0, wall_s=1.0,
                     mussels=[])


def test_the_paper_row_stands_only_beside_a_run_made_as_the_papers() -> None:
    paper = _result(2400.0, 30.0)
    for runs, rows in (([paper], 1), ([replace(paper, duration_s=6 * 3600.0)], 0),
                       ([replace(paper, theta=60.0)], 0), ([paper, replace(paper, duration_s=600.0)], 1)):
        console = Console(record=True, width=200)
        console.print(results_table(runs))
        text = console.export_text()
        assert text.count("72.27") == rows and ("the paper's Table II" in text) == bool(rows), text


@pytest.mark.sitl
def test_ctrl_c_past_an_hour_says_the_mission_time_in_hours_and_the_summary_too(tmp_path: Path) -> None:
    folder = RunFolder(tmp_path / "out" / "pool12-cautious-seed1-run1")
    # 3 h, not 90 min: on an idle machine the half hour after the first checkpoint past the hour could end
    # before the Ctrl-C landed (exit 0, a fresh clone's suite); two hours cannot.
    code, err = ctrl_c_after_checkpoint([*VIL, "pool12", "--duration", "3h", "--out", "out"], tmp_path, ENV,
                                        folder.checkpoint, 3660.0, WALL_TIMEOUT_S)  # past the first hour
    assert code == 130, err
    at = re.search(r"\(mission time ([^)]*)\)", err)
    assert at is not None and re.fullmatch(r"1:\d\d:\d\d", at.group(1)), err  # e.g. 1:01:00, not 61:00
    done = subprocess.run([*VIL, "pool12", "--duration", "3h", "--out", "out", "--resume"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=WALL_TIMEOUT_S, env=ENV)
    assert done.returncode == 0, done.stderr
    assert f"from its checkpoint at {at.group(1)}" in done.stderr
    assert "1 run(s) of 3:00:00 mission time" in done.stdout and "paper" not in done.stdout


def test_resuming_with_other_settings_is_one_line_before_anything_runs(tmp_path: Path) -> None:
    folder = RunFolder(tmp_path / "out" / "pool12-cautious-seed1-run1")
    # 3 h, not the scenario's 40 min: on an idle machine pool12's 40 min can end before the Ctrl-C lands
    code, _ = ctrl_c_after_checkpoint([*VIL, "pool12", "--duration", "3h", "--out", "out"], tmp_path, ENV,
                                      folder.checkpoint, 300.0, WALL_TIMEOUT_S)
    assert code == 130
    kept = folder.checkpoint.read_bytes()
    done = subprocess.run([*VIL, "pool12", "--duration", "3h", "--out", "out", "--loss", "0.1", "--resume"],
                          cwd=tmp_path,
                          capture_output=True, text=True, timeout=WALL_TIMEOUT_S, env=ENV)
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr and done.stderr.count("\n") == 1, done.stderr
    assert "started with other settings" in done.stderr
    assert folder.checkpoint.read_bytes() == kept  # nothing cut, nothing run: the right flags still resume it
