"""The summary of `vil run` says what happened that the figures do not (issue 23): the lost aPad
of `--fail-apad` (in its row and a line), the outage and the failsafe hold the README promises."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.sitl, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[2]


def _run(tmp_path: Path, *args: str) -> tuple[str, dict[str, object]]:
    env = {k: v for k, v in os.environ.items() if k != "COLUMNS"} | {"PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-m", "gcs.cli", "run", *args, "--json", "r.json"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=300, env=env)
    assert done.returncode == 0, done.stderr
    return done.stdout, json.loads((tmp_path / "r.json").read_text())


def test_a_failed_apad_is_named_lost_in_its_row_and_in_what_happened(tmp_path: Path) -> None:
    out, result = _run(tmp_path, "pool12x2", "--fail-apad", "2:300s", "--duration", "10min")
    (lost,) = result["happened"]["apads_lost"]  # type: ignore[index]
    assert lost["apad"] == 2 and 300 < lost["at_s"] < 330
    row = next(line for line in out.splitlines() if line.split()[:1] == ["2"])
    assert "lost at 05:" in row
    (line,) = [x for x in out.splitlines() if x.startswith("pool12x2 cautious s1:")]
    assert "aPad 2 made to fail at 05:00" in line and "aPad 2 lost at 05:" in line and "fleet re-shared x1" in line


def test_the_readme_outage_example_holds_the_apad_and_says_so(tmp_path: Path) -> None:
    """README: `vil run pool12 --strategy greedy --outage 92s:112s`: the failsafe holds, the GCS resumes."""
    out, result = _run(tmp_path, "pool12", "--strategy", "greedy", "--outage", "92s:112s", "--duration", "10min")
    happened = result["happened"]
    assert happened["faults"] == {"outages_s": [[92.0, 112.0]]}  # type: ignore[index]
    assert happened["failsafe_holds"] >= 1 and happened["gotos_resumed"] >= 1  # type: ignore[index,operator]
    (line,) = [x for x in out.splitlines() if x.startswith("pool12 greedy s1:")]
    assert "link faults: outage 01:32-01:52" in line and "failsafe hold x" in line
