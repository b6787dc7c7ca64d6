"""`python -m mavlink_dialect.run_with_dialect SCRIPT ...`: pymavlink tools load our dialect by name.

The launcher changes the interpreter it runs in (sys.modules, MAVLINK20), so everything but the
argument errors runs in a child process.
"""

from __future__ import annotations

import struct
import subprocess
import sys
from pathlib import Path

import pytest

from mavlink_dialect import Codec, mavlink
from mavlink_dialect.run_with_dialect import find_script, main

BIN = Path(sys.executable).parent


def launch(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mavlink_dialect.run_with_dialect", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=30, check=False)


def test_an_unknown_script_is_an_error_naming_it(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["no_such_tool.py", "--dialect", "subcultron"]) == 2
    assert "no script 'no_such_tool.py'" in capsys.readouterr().err
    assert main(["/nowhere/mavlogdump.py"]) == 2  # a path that does not exist is not looked up elsewhere


def test_no_arguments_prints_the_usage(capsys: pytest.CaptureFixture[str]) -> None:
    assert main([]) == 2
    assert "run_with_dialect mavproxy.py" in capsys.readouterr().out


def test_console_scripts_are_found_beside_the_interpreter() -> None:
    assert find_script("mavlogdump.py") == BIN / "mavlogdump.py"


def test_the_script_runs_as_main_with_its_arguments_and_mavutil_loads_subcultron(tmp_path: Path) -> None:
    script = tmp_path / "probe.py"
    script.write_text(
        "import sys\n"
        "from pymavlink import mavutil\n"
        "mavutil.set_dialect('subcultron')\n"
        "m = mavutil.mavlink\n"
        "print(__name__, m.MAVLINK_MSG_ID_AMUSSEL_STATUS, m.WIRE_PROTOCOL_VERSION, mavutil.current_dialect,\n"
        "      sys.argv[1:])\n"
        "sys.exit(3)\n",
        encoding="utf-8",
    )
    done = launch(str(script), "a", "--b", cwd=tmp_path)
    assert done.returncode == 3, done.stderr
    assert done.stdout.split("\n")[0] == "__main__ 54000 2.0 subcultron ['a', '--b']"


def test_mavlogdump_names_our_messages_only_through_the_launcher(tmp_path: Path) -> None:
    codec = Codec(251, 25)
    msg = mavlink.MAVLink_amussel_status_message(42, 7, 439400000, 154400000, 1.5, 0.25, 3800, 0, 1)
    tlog = tmp_path / "one.tlog"
    tlog.write_bytes(struct.pack(">Q", 1_700_000_000_000_000) + codec.encode(msg))

    plain = subprocess.run([sys.executable, str(BIN / "mavlogdump.py"), str(tlog)], cwd=tmp_path,
                           capture_output=True, text=True, timeout=30, check=False)
    assert "UNKNOWN_54000" in plain.stdout  # stock pymavlink: ardupilotmega knows nothing of ours

    done = launch("mavlogdump.py", "--dialect", "subcultron", str(tlog), cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert ("AMUSSEL_STATUS {time_us : 42, mussel_id : 7, lat : 439400000, lon : 154400000, depth : 1.5, "
            "battery : 0.25, battery_voltage : 3800, state : 0, simulated : 1}") in done.stdout
