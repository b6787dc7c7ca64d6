"""Hostile valid-CRC packets over real UDP at a running `vil sitl` and a running `vil run --proxy`:
both go on working (the sitl answers a real GCS afterwards; the run ends 0 with every aMussel
accounted for, the spray counted in its result.json)."""

from __future__ import annotations

import contextlib
import json
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from hostile_packets import GCS_ORDERS, MESSAGE_CLASSES, STRANGERS, HostileFrames, senders
from testkit import free_udp_port

from mavlink_dialect import Codec, mavlink

pytestmark = [pytest.mark.sitl, pytest.mark.slow]
ROOT = Path(__file__).resolve().parents[2]
QUIET = [cls for cls in MESSAGE_CLASSES if cls.msgname not in GCS_ORDERS]  # see test_fuzz_hostile_fields



def spray(sock: socket.socket, gen: HostileFrames, ports: list[int], n: int) -> None:
    """`n` frames to each port, in bursts, so the receiver reads them between its own work."""
    for i in range(n):
        frame = gen.frame()
        for port in ports:
            with contextlib.suppress(OSError):  # a port already closed (the run ended) refuses
                sock.sendto(frame, ("127.0.0.1", port))
        if i % 100 == 99:
            time.sleep(0.005)


def test_vil_sitl_survives_a_spray_and_still_answers_a_gcs(tmp_path: Path) -> None:
    port = free_udp_port()
    proc = subprocess.Popen([sys.executable, "-m", "gcs.cli", "sitl", "--listen", f"udp:127.0.0.1:{port}",
                             "--duration", "30s", "--log-dir", str(tmp_path)], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None and "listening on" in proc.stdout.readline()
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            spray(sock, HostileFrames(11, senders(*STRANGERS, (250, 190))), [port], 5000)
        assert proc.poll() is None, "vil sitl died of a packet"
        arm = mavlink.MAVLink_command_long_message(1, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            sock.settimeout(0.1)
            # A GCS the spray never spoofed: the vehicle may still be answering the spray's own commands
            # from (250, 190) when this one starts, and a COMMAND_ACK does not say which command it answers.
            gcs = Codec(251, 190)
            acks, beats, deadline = [], 0, time.monotonic() + 5.0
            while not (acks and beats) and time.monotonic() < deadline:
                sock.sendto(gcs.encode(arm), ("127.0.0.1", port))
                with contextlib.suppress(TimeoutError):
                    for msg in gcs.decode(sock.recvfrom(65535)[0]):
                        beats += msg.get_type() == "HEARTBEAT" and msg.get_srcSystem() == 1
                        if msg.get_type() == "COMMAND_ACK" and msg.target_system == 251:
                            acks.append(msg.result)
        assert beats and acks and acks[0] == mavlink.MAV_RESULT_ACCEPTED
    finally:
        proc.terminate()
        _, err = proc.communicate(timeout=10)
    assert "Traceback" not in err
    events = [json.loads(line) for line in (tmp_path / "apad1.events.jsonl").read_text().splitlines()]
    assert not [e for e in events if e["event"] == "handler_error"]


def test_vil_run_with_a_proxy_survives_a_spray_on_every_socket(tmp_path: Path) -> None:
    proc = subprocess.Popen([sys.executable, "-m", "gcs.cli", "run", "pool12", "--proxy", "--out", str(tmp_path),
                             "--jobs", "1"], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 20.0
        while not (found := list(tmp_path.glob("*/endpoints.json"))) and time.monotonic() < deadline:
            time.sleep(0.02)
        assert found, "the run wrote no endpoints.json"
        time.sleep(0.05)  # written whole: one write of a short line
        ports = json.loads(found[0].read_text())
        apad_side = [*ports["apad"].values(), *ports["proxy"]]
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            spray(sock, HostileFrames(12, senders(*STRANGERS)), ports["gcs"], 2000)
            spray(sock, HostileFrames(13, senders(*STRANGERS), classes=QUIET), apad_side, 2000)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err
    result = json.loads(next(tmp_path.glob("*/result.json")).read_text())
    assert result["end_reason"] == "mission time"
    assert len(result["whereabouts"]) == 12
    assert {w["where"] for w in result["whereabouts"]} <= {"seabed", "slot"}
    counted = result["messages"]
    gcs_drops = sum(n for k, n in counted.items() if k.startswith("gcs_dropped."))
    apad_drops = sum(n for k, n in counted.items() if k.startswith("apad_dropped."))
    assert gcs_drops > 100 and apad_drops > 10, counted  # the spray reached both, and was refused
    assert not [k for k in counted if "handler_error" in k]
