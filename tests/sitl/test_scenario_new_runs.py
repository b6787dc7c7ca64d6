"""`vil scenario new` writes a scenario that `vil scenario check` accepts and `vil run` runs, from a
folder of its own (issue 22): the commands as a user types them, in fresh processes."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from gcs.scenario.reader import load_scenario

pytestmark = [pytest.mark.sitl]

ROOT = Path(__file__).resolve().parents[2]


def _vil(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "gcs.cli", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=120, env={**os.environ, "PYTHONPATH": str(ROOT)})


def test_a_new_scenario_is_checked_and_runs(tmp_path: Path) -> None:
    area = ROOT / "missions" / "areas" / "bay.geojson"
    made = _vil("scenario", "new", str(area), "--count", "6", "-o", "mine.toml", cwd=tmp_path)
    assert made.returncode == 0 and made.stderr == "", made.stderr
    checked = _vil("scenario", "check", "mine.toml", cwd=tmp_path)
    assert checked.returncode == 0, checked.stderr
    assert checked.stdout == "mine.toml: ok: mine, 6 aMussels, 1 aPad, 40 min\n"
    assert load_scenario(tmp_path / "mine.toml").fleet.area == area
    ran = _vil("run", "mine.toml", "--duration", "2m", cwd=tmp_path)
    assert ran.returncode == 0, ran.stderr
    assert "mine-cautious-seed1-run1/" in " ".join(ran.stdout.split())
