"""Output written to a file or a pipe is whole (issue 23): rich would cut tables and lines at 80
columns where there is no terminal; a real `vil run` of several runs into a pipe, no $COLUMNS."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.sitl, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[2]


def test_a_multi_run_table_in_a_pipe_has_every_name_and_figure_whole(tmp_path: Path) -> None:
    env = {k: v for k, v in os.environ.items() if k != "COLUMNS"} | {"PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-m", "gcs.cli", "run", "pool12", "--strategy", "route_optimal,lookahead",
                           "--seeds", "2", "--duration", "6min", "--jobs", "2"], cwd=tmp_path, capture_output=True,
                          text=True, timeout=300, env=env)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    rows = [line.split() for line in lines if line.split()[:1] == ["pool12"]]
    assert [r[1] for r in rows] == ["route_optimal", "lookahead"]  # no "route_optim..."
    assert all(len(r) == 8 and all("…" not in cell for cell in r) for r in rows), rows
    (summary,) = [line for line in lines if line.startswith("4 run(s)")]  # one line, naming every folder
    assert all(f"runs/pool12-{s}-seed{k}-run1/" in summary for s in ("route_optimal", "lookahead") for k in (1, 2))
