"""A real `vil sitl` process with signing on, over UDP: stray unsigned MAVLink is ignored, signed is obeyed."""

from __future__ import annotations

import contextlib
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mavlink_dialect import Codec, mavlink, signing

pytestmark = [pytest.mark.sitl, pytest.mark.slow]


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def exchange(sock: socket.socket, codec: Codec, port: int, msg: mavlink.MAVLink_message, seconds: float) -> list:
    sock.sendto(codec.encode(msg), ("127.0.0.1", port))
    got = []
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        with contextlib.suppress(TimeoutError):
            got.extend(codec.decode(sock.recvfrom(65535)[0]))
    return got


def test_a_signing_sitl_process_ignores_a_stray_unsigned_gcs(tmp_path: Path) -> None:
    port = free_udp_port()
    env = {**os.environ, signing.KEY_ENV: "biograd 2020"}
    proc = subprocess.Popen([sys.executable, "-m", "gcs.cli", "sitl", "--listen", f"udp:127.0.0.1:{port}",
                             "--duration", "30"], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env, text=True)
    try:
        assert proc.stdout is not None and "listening on" in proc.stdout.readline()
        arm = mavlink.MAVLink_command_long_message(1, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 0, 0, 0, 0, 0, 0, 0)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            sock.settimeout(0.1)
            stray = Codec(250, 190)
            answers = exchange(sock, stray, port, arm, 2.0)
            assert not [m for m in answers if m.get_type() == "COMMAND_ACK"]
            assert any(m.get_type() == "HEARTBEAT" for m in answers)  # it was heard and answered nothing
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            sock.settimeout(0.1)
            gcs = Codec(250, 190)
            gcs.enable_signing(signing.key_from_passphrase("biograd 2020"), 1,
                               lambda: signing.timestamp_ticks(time.time_ns() // 1000, 0))
            answers = exchange(sock, gcs, port, arm, 2.0)
            acks = [m for m in answers if m.get_type() == "COMMAND_ACK"]
            assert [a.result for a in acks] == [mavlink.MAV_RESULT_ACCEPTED]
            assert gcs.stats.bad_data == 0
    finally:
        proc.terminate()
        proc.wait(10)
        if proc.stdout is not None:
            proc.stdout.close()
