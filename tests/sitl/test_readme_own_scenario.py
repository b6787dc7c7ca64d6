"""The README's "A scenario of your own" example, run as written (issue 23: docs whose examples the
suite runs), and the error that explains where scenario paths are taken from."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.sitl]

ROOT = Path(__file__).resolve().parents[2]


def _example() -> str:
    readme = (ROOT / "README.md").read_text()
    section = readme.split("## A scenario of your own", 1)[1]
    (block,) = re.findall(r"```\n(.*?)```", section.split("\n## ", 1)[0], re.S)
    return block


def test_the_readme_example_of_a_scenario_of_ones_own_runs_as_written(tmp_path: Path) -> None:
    (tmp_path / "missions").symlink_to(ROOT / "missions")  # the example runs from the repository's root
    script = f'vil() {{ "{sys.executable}" -m gcs.cli "$@"; }}\nset -e\n{_example()}'
    done = subprocess.run(["bash", "-c", script], cwd=tmp_path, capture_output=True, text=True, timeout=120,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert done.returncode == 0, done.stderr
    assert "pool12-greedy-seed1-run1/" in " ".join(done.stdout.split())


def test_a_copied_scenario_whose_paths_do_not_follow_says_where_paths_are_taken_from(tmp_path: Path) -> None:
    (tmp_path / "mine.toml").write_text((ROOT / "missions" / "pool12.toml").read_text())
    done = subprocess.run([sys.executable, "-m", "gcs.cli", "run", "mine.toml"], cwd=tmp_path, capture_output=True,
                          text=True, timeout=60, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert "relative to the scenario file's folder" in done.stderr and str(tmp_path.resolve()) in done.stderr
