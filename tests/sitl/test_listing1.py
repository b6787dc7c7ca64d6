"""The paper's Listing 1 (missions/listing1.py) against a real `vil sitl` process over UDP."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest
from testkit import free_udp_port

pytestmark = [pytest.mark.sitl, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[2]



def listing1(port: int) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, str(ROOT / "missions" / "listing1.py"), "--connect", f"udp:127.0.0.1:{port}",
         "--distance", "4", "--timeout", "40"],
        capture_output=True, text=True, timeout=60,
    )


def test_listing1_goes_to_amussel_24_and_docks_it_in_slot_2(tmp_path: Path) -> None:
    """Run twice against the same aPad: the second Dock finds slot 2 holding aMussel 24 and is refused
    in words (it used to be accepted with nothing to report, and the script waited forever)."""
    port = free_udp_port()
    # A brisk aPad (the defaults' 0.25 m/s^2 made the 4-m Go To take 6 s): the same Go To, then Dock.
    sitl = subprocess.Popen(
        [sys.executable, "-m", "apad_sitl", "--listen", f"udp:127.0.0.1:{port}", "--param", "DOCK_TIME=1",
         "--param", "SPEED_MAX=2.0", "--param", "ACCEL_MAX=1.0", "--duration", "60s", "--log-dir", str(tmp_path)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    try:
        time.sleep(0.5)
        done = listing1(port)
        again = listing1(port)
    finally:
        sitl.terminate()
        sitl.communicate(timeout=10)
    assert done.returncode == 0, done.stdout + done.stderr
    lines = done.stdout.splitlines()
    assert "GoTo in progress." in lines
    assert lines.index("Goal reached. Docking start.") > lines.index("GoTo in progress.")
    assert lines[-1] == "Docking done: slot 2 holds aMussel 24 (LATCHED, charging)."
    # The aPad's own log agrees: a dock of aMussel 24 into slot 2 was commanded and completed.
    events = (tmp_path / "apad1.events.jsonl").read_text()
    assert '"mussel_id":24' in events and '"slot":2' in events
    assert again.returncode == 1 and "Goal reached. Docking start." in again.stdout
    assert "slot 2 occupied" in again.stderr and "Traceback" not in again.stderr


def test_listing1_without_an_apad_says_so_and_fails() -> None:
    done = subprocess.run(
        [sys.executable, str(ROOT / "missions" / "listing1.py"), "--connect", f"udp:127.0.0.1:{free_udp_port()}",
         "--wait", "1.5"],
        capture_output=True, text=True, timeout=30,
    )
    assert done.returncode == 1
    assert "no heartbeat from an aPad within 1.5 s" in done.stderr and "Traceback" not in done.stderr
