"""Exposure: loopback binds by default, stream rates clamped, UDP peers pruned, every queue bounded and counted."""

from __future__ import annotations

import contextlib
import itertools
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from robust_helpers import sitl_pair

from apad_sitl import serve
from apad_sitl.streams import MIN_INTERVAL_US
from gcs.link.faultproxy import FaultProxy, LinkFaults
from mavlink_dialect import Codec, mavlink, memory_pair, open_transport
from mavlink_dialect.transport import MAX_CLIENTS, MAX_PEERS, TcpTransport, UdpTransport, local_address_towards
from missiontime import VirtualClock

pytestmark = pytest.mark.sitl
ATTITUDE = mavlink.MAVLINK_MSG_ID_ATTITUDE


def free_port(kind: int = socket.SOCK_DGRAM) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def client() -> socket.socket:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    sock.setblocking(False)
    return sock


def received(sock: socket.socket) -> list[bytes]:
    out = []
    time.sleep(0.05)  # loopback delivery is immediate; this only lets the kernel settle
    with contextlib.suppress(BlockingIOError):
        while True:
            out.append(sock.recv(65535))
    return out


def arrive(transport: UdpTransport) -> list[bytes]:
    """One receive call, once what was just sent over loopback has landed."""
    time.sleep(0.05)
    return transport.receive()


# ---- bind addresses ------------------------------------------------------------------------------


def test_every_default_binds_loopback_and_a_connecting_socket_never_binds_all_interfaces() -> None:
    assert serve.DEFAULT_LISTEN.startswith("udp:127.0.0.1:")
    port = free_port()
    gcs = open_transport(f"udp:127.0.0.1:{port}")  # what `vil gcs --connect` and `vil sitl --connect` open
    assert isinstance(gcs, UdpTransport) and gcs.local_host == "127.0.0.1"  # was 0.0.0.0
    gcs.close()
    named = open_transport(f"udp:localhost:{port}")
    assert isinstance(named, UdpTransport) and named.local_host == "127.0.0.1"
    named.close()
    proxy = FaultProxy(VirtualClock(), ("127.0.0.1", port), LinkFaults())
    assert proxy.gcs_side.transport.local_host == "127.0.0.1"
    assert proxy.vehicle_side.transport.local_host == "127.0.0.1"
    proxy.close()
    try:
        towards = local_address_towards("192.0.2.1", 14550)  # TEST-NET-1: only the route is asked
    except OSError:
        pytest.skip("no route off this machine to check a non-loopback peer")
    assert towards != "0.0.0.0"


def test_a_connecting_socket_answers_only_its_peer_not_whoever_writes_to_it() -> None:
    vehicle = client()
    gcs = UdpTransport("127.0.0.1", vehicle.getsockname()[1], listen=False)
    stranger = client()
    try:
        stranger.sendto(b"hello", ("127.0.0.1", gcs.local_port))
        assert arrive(gcs) == [b"hello"]  # replies may come from anywhere on the bound interface
        gcs.send(b"command")
        assert received(vehicle) == [b"command"] and received(stranger) == []
    finally:
        for s in (vehicle, stranger):
            s.close()
        gcs.close()


# ---- stream rates --------------------------------------------------------------------------------


def test_a_1_us_message_interval_is_clamped_to_20_ms() -> None:
    clock, vehicle, gcs = sitl_pair()
    gcs.command_long(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, ATTITUDE, 1)
    [ack] = gcs.acks(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL)
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED  # ACCEPTED, clamped (apad_sitl/streams.py says so)
    start = len(gcs.inbox)
    clock.sleep(2.0)
    stamps = [m.time_boot_ms for m in gcs.inbox[start:] if m.get_type() == "ATTITUDE"]
    gaps_ms = {b - a for a, b in itertools.pairwise(stamps)}
    assert len(stamps) == 100 and gaps_ms == {MIN_INTERVAL_US // 1000}  # 50 Hz, not a million a second
    gcs.command_long(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, ATTITUDE, 50_000)  # slower than the bound: as asked
    start = len(gcs.inbox)
    clock.sleep(1.0)
    assert sum(m.get_type() == "ATTITUDE" for m in gcs.inbox[start:]) == 20
    vehicle.close()


@pytest.mark.slow
def test_a_real_sitl_process_clamps_a_1_us_interval(tmp_path: Path) -> None:
    port = free_port()
    proc = subprocess.Popen([sys.executable, "-m", "gcs.cli", "sitl", "--listen", f"udp:127.0.0.1:{port}",
                             "--duration", "30s"], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    codec = Codec(250, 190)
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    sock.settimeout(0.05)
    try:
        assert proc.stdout is not None and "listening on" in proc.stdout.readline()
        sock.sendto(codec.encode(mavlink.MAVLink_command_long_message(
            1, 1, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0, ATTITUDE, 1, 0, 0, 0, 0, 0)), ("127.0.0.1", port))
        msgs = []
        deadline = time.monotonic() + 2.0
        while time.monotonic() < deadline:
            with contextlib.suppress(TimeoutError):
                msgs.extend(codec.decode(sock.recv(65535)))
    finally:
        sock.close()
        proc.terminate()
        proc.communicate(timeout=10)
    [ack] = [m for m in msgs if m.get_type() == "COMMAND_ACK"]
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED
    stamps = [m.time_boot_ms for m in msgs if m.get_type() == "ATTITUDE"]
    span_ms = stamps[-1] - stamps[0]
    print(f"\nATTITUDE after a 1 us interval: {len(stamps)} in {span_ms} ms of the aPad's time")
    # At most 50 Hz by the aPad's own clock. A stream that fell behind on a loaded machine catches up
    # with a burst stamped at one instant: the first stamp's burst bounds how late the stream began.
    first_burst = stamps.count(stamps[0])
    assert span_ms > 1000 and len(stamps) <= span_ms // 20 + first_burst + 1


# ---- UDP peers -----------------------------------------------------------------------------------


class FakeTime:
    def __init__(self) -> None:
        self.t = 1000.0

    def __call__(self) -> float:
        return self.t


def test_udp_peers_silent_for_30_s_are_pruned() -> None:
    now = FakeTime()
    server = UdpTransport("127.0.0.1", 0, listen=True, now_s=now)
    clients = [client() for _ in range(3)]
    try:
        for c in clients:
            c.sendto(b"hi", ("127.0.0.1", server.local_port))
        assert len(arrive(server)) == 3 and len(server.peers) == 3
        now.t += 29.0
        clients[0].sendto(b"still here", ("127.0.0.1", server.local_port))
        assert arrive(server) == [b"still here"]
        now.t += 2.0  # 31 s since the other two spoke
        server.send(b"telemetry")
        assert server.peers == [clients[0].getsockname()]
        assert [len(received(c)) for c in clients] == [1, 0, 0]
        assert server.pruned == 2
        clients[1].sendto(b"back", ("127.0.0.1", server.local_port))  # a pruned peer that speaks is served again
        arrive(server)
        assert len(server.peers) == 2
    finally:
        for c in clients:
            c.close()
        server.close()


def test_past_max_peers_a_newcomer_is_refused_and_counted_until_a_place_frees() -> None:
    now = FakeTime()
    server = UdpTransport("127.0.0.1", 0, listen=True, now_s=now)
    clients = [client() for _ in range(MAX_PEERS + 1)]
    try:
        for c in clients[:-1]:
            c.sendto(b"hi", ("127.0.0.1", server.local_port))
        assert len(arrive(server)) == MAX_PEERS
        clients[-1].sendto(b"me too", ("127.0.0.1", server.local_port))
        assert arrive(server) == []
        assert server.dropped == {"peer_limit": 1} and len(server.peers) == MAX_PEERS
        now.t += 31.0
        clients[-1].sendto(b"me too", ("127.0.0.1", server.local_port))
        assert arrive(server) == [b"me too"] and server.peers == [clients[-1].getsockname()]
    finally:
        for c in clients:
            c.close()
        server.close()


# ---- queues --------------------------------------------------------------------------------------


def test_one_udp_receive_takes_at_most_its_batch_the_rest_waits() -> None:
    server = UdpTransport("127.0.0.1", 0, listen=True)
    server.max_batch = 4
    c = client()
    try:
        for i in range(10):
            c.sendto(bytes([i]), ("127.0.0.1", server.local_port))
        time.sleep(0.05)
        batches = [server.receive() for _ in range(4)]
        assert [len(b) for b in batches] == [4, 4, 2, 0]
        assert b"".join(b"".join(b) for b in batches) == bytes(range(10))  # nothing lost, in order
    finally:
        c.close()
        server.close()


def test_an_in_memory_inbox_is_bounded_and_counts_what_it_drops() -> None:
    a, b = memory_pair()
    b.max_inbox = 3
    for i in range(5):
        a.send(bytes([i]))
    assert b.receive() == [b"\x00", b"\x01", b"\x02"]
    assert b.dropped == {"inbox_full": 2}


def test_a_tcp_listener_keeps_at_most_max_clients() -> None:
    port = free_port(socket.SOCK_STREAM)
    server = TcpTransport("127.0.0.1", port, listen=True)
    conns: list[socket.socket] = []
    try:
        for _ in range(MAX_CLIENTS + 2):  # one at a time: the listen backlog is short
            conns.append(socket.create_connection(("127.0.0.1", port), timeout=2.0))
            time.sleep(0.02)
            server.receive()
        assert len(server.clients) == MAX_CLIENTS and server.dropped == {"client_limit": 2}
    finally:
        for conn in conns:
            conn.close()
        server.close()


def test_the_fault_proxy_holds_at_most_max_held_and_counts_the_overflow() -> None:
    clock = VirtualClock()
    vehicle = client()
    proxy = FaultProxy(clock, vehicle.getsockname(), LinkFaults(latency_s=10.0))
    proxy.max_held = 5
    gcs = client()
    try:
        for i in range(8):
            gcs.sendto(bytes([i]), ("127.0.0.1", proxy.listen_port))
        time.sleep(0.05)
        clock.sleep(0.0)
        stats = proxy.stats[True]
        assert stats.overflow == 3
        clock.sleep(10.0)
        assert received(vehicle) == [bytes([i]) for i in range(5)] and stats.forwarded == 5
    finally:
        proxy.close()
        vehicle.close()
        gcs.close()
