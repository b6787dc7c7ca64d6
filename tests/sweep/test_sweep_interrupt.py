"""Ctrl-C in `vil sweep` (issue 23): as a terminal sends it, to the whole process group (the Dask
workers too): one line, what was kept and that running it again continues; no worker tracebacks;
exit 130. Then the same command finishes what was left. A real process, a real local cluster."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from testkit import sigint_as_in_a_terminal

pytestmark = [pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[2]
# Short missions: the Ctrl-C comes as the first is kept, with five still to run (a second or more of work).
SPEC = """
[sweep]
scenarios = ["pool12"]
strategies = ["cautious", "greedy"]
seeds = [1, 2, 3]
[set]
mission.duration = "4m"
"""


def test_ctrl_c_of_a_sweep_is_one_line_and_running_it_again_finishes(tmp_path: Path) -> None:
    (tmp_path / "six.toml").write_text(SPEC)
    cmd = [sys.executable, "-m", "gcs.cli", "sweep", "six.toml", "--out", "out", "--workers", "2"]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    with sigint_as_in_a_terminal():
        proc = subprocess.Popen(cmd, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                                start_new_session=True)  # its own process group, as a terminal's job
    try:
        deadline = time.monotonic() + 120
        while not list((tmp_path / "out" / "cells").glob("*.json")):  # one mission done: something to keep
            assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
            time.sleep(0.1)
        os.killpg(proc.pid, signal.SIGINT)  # what Ctrl-C in a terminal does
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    kept = len(list((tmp_path / "out" / "cells").glob("*.json")))
    assert proc.returncode == 130, err
    assert "Traceback" not in err and err.count("\n") == 1, err
    assert f"interrupted; {kept} of 6 missions are in out: run it again to continue" in err

    again = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=300, env=env)
    assert again.returncode == 0, again.stderr
    assert f"{kept} already in out" in again.stdout
    assert len(list((tmp_path / "out" / "cells").glob("*.json"))) == 6


def test_the_message_after_an_interruption_starts_a_line_of_its_own() -> None:
    """Output to a file: a progress line cut short by Ctrl-C is ended before the message (stderr, the same file)."""
    import io

    from gcs.cli.sweep import LineEnds

    both = io.StringIO()
    lines = LineEnds(both)
    lines.write("sweep ━━━━━━━━━━ 1/6 missions 0:00:03")
    lines.end_line()
    both.write("vil sweep: interrupted; ...\n")
    assert both.getvalue().splitlines() == ["sweep ━━━━━━━━━━ 1/6 missions 0:00:03", "vil sweep: interrupted; ..."]
    lines.end_line()  # a line already ended: nothing added
    assert both.getvalue().endswith("interrupted; ...\n")
