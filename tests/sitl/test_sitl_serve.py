"""`python -m apad_sitl` / `vil sitl`: the real-time server as a user runs it."""

from __future__ import annotations

import argparse
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from testkit import free_udp_port

from apad_sitl.serve import add_arguments, run
from mavlink_dialect import Codec, mavlink

pytestmark = pytest.mark.sitl
ROOT = Path(__file__).resolve().parents[2]



def parse(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="vil sitl")
    add_arguments(parser)
    return parser.parse_args(argv)


def test_the_server_subprocess_serves_heartbeats_over_udp_and_stops_cleanly_on_ctrl_c(tmp_path: Path) -> None:
    port = free_udp_port()
    cmd = [sys.executable, "-m", "apad_sitl", "--listen", f"udp:127.0.0.1:{port}", "--duration", "5s",
           "--sysid", "7", "--log-dir", str(tmp_path)]
    with subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as proc, \
            socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        gcs = Codec(250, 190)
        hello = gcs.encode(mavlink.MAVLink_heartbeat_message(
            mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3))
        sock.settimeout(0.2)
        heartbeat = None
        deadline = time.monotonic() + 10.0
        while heartbeat is None and time.monotonic() < deadline:
            sock.sendto(hello, ("127.0.0.1", port))  # until the server is up and knows us
            try:
                data = sock.recv(65535)
            except TimeoutError:
                continue
            heartbeat = next((m for m in gcs.decode(data) if m.get_type() == "HEARTBEAT"), None)
        assert heartbeat is not None, "no HEARTBEAT from the server"
        assert heartbeat.get_srcSystem() == 7 and heartbeat.type == mavlink.MAV_TYPE_SURFACE_BOAT
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=5)
    assert proc.returncode == 0, err
    assert err == ""
    assert out.splitlines() == [
        f"vil sitl: aPad sysid 7 listening on udp:127.0.0.1:{port}, home 43.940000,15.439838 (the default, "
        f"pool12's: --home LAT,LON or --scenario NAME to choose), current 0,0 m/s, logs in {tmp_path}"
    ]
    events = (tmp_path / "apad7.events.jsonl").read_text().splitlines()
    assert '"event":"close"' in events[-1]
    assert (tmp_path / "apad7.tlog").stat().st_size > 0


def test_bad_address_is_one_line_and_exit_code_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert run(parse("--listen", "udp:nowhere")) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("vil sitl: bad address 'udp:nowhere'")


def test_port_in_use_is_one_line_and_exit_code_2(capsys: pytest.CaptureFixture[str]) -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as busy:
        busy.bind(("127.0.0.1", 0))
        port = busy.getsockname()[1]
        assert run(parse("--listen", f"udp:127.0.0.1:{port}", "--duration", "0.1s")) == 2
    err = capsys.readouterr().err
    assert err == f"vil sitl: cannot open udp:127.0.0.1:{port}: Address already in use\n"


def test_connect_runs_for_the_duration_and_sends_to_the_gcs(capsys: pytest.CaptureFixture[str]) -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as gcs:
        gcs.bind(("127.0.0.1", 0))
        port = gcs.getsockname()[1]
        start = time.monotonic()
        args = parse("--connect", f"udp:127.0.0.1:{port}", "--duration", "0.5s", "--home", "45.43,12.33",
                     "--current", "0.1,-0.05", "--param", "speed_max=0.3")
        assert run(args) == 0
        assert time.monotonic() - start >= 0.5  # it ran for the whole duration, not less
        gcs.settimeout(0.5)
        msgs = Codec(250, 190).decode(gcs.recv(65535))
    assert msgs[0].get_type() == "HEARTBEAT"
    assert "connecting to" in capsys.readouterr().out


@pytest.mark.parametrize(("argv", "message"), [
    (["--home", "91,0"], "latitude must be in [-90, 90]"),
    (["--current", "x"], "two numbers"),
    (["--sysid", "0"], "1..255"),
    (["--param", "SPEED_MAX=9"], "outside"),
    (["--param", "NOPE=1"], "unknown parameter"),
    (["--duration", "-1"], "positive"),
    (["--listen", "udp:127.0.0.1:1", "--connect", "udp:127.0.0.1:2"], "not allowed with"),
])
def test_bad_arguments_exit_2_with_a_message(argv: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        parse(*argv)
    assert exc.value.code == 2
    assert message in capsys.readouterr().err
