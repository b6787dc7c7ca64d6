"""Transports: real sockets, a real pty for serial, the in-memory pair, and clear address errors."""

from __future__ import annotations

import os
import socket
import time

import pytest

from mavlink_dialect import AddressError, memory_pair, open_transport
from mavlink_dialect.transport import Transport


def free_port(kind: int = socket.SOCK_DGRAM) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def receive_within(t: Transport, timeout_s: float = 2.0) -> bytes:
    deadline = time.monotonic() + timeout_s
    got = b""
    while time.monotonic() < deadline:
        got += b"".join(t.receive())
        if got:
            return got
        time.sleep(0.005)
    return got


def test_memory_pair_delivers_both_ways_in_order() -> None:
    a, b = memory_pair()
    a.send(b"one")
    a.send(b"two")
    b.send(b"back")
    assert b.receive() == [b"one", b"two"]
    assert a.receive() == [b"back"]
    assert b.receive() == []


def test_udp_listener_answers_whoever_spoke() -> None:
    port = free_port()
    server = open_transport(f"udp:127.0.0.1:{port}", listen=True)
    client = open_transport(f"udp:127.0.0.1:{port}")
    try:
        server.send(b"nobody yet")  # no peer heard: dropped, not an error
        client.send(b"hello")
        assert receive_within(server) == b"hello"
        server.send(b"welcome")
        assert receive_within(client) == b"welcome"
    finally:
        server.close()
        client.close()


def test_tcp_stream_both_ways() -> None:
    port = free_port(socket.SOCK_STREAM)
    server = open_transport(f"tcp:127.0.0.1:{port}", listen=True)
    client = open_transport(f"tcp:127.0.0.1:{port}")
    try:
        client.send(b"ping")
        assert receive_within(server) == b"ping"
        server.send(b"pong")
        assert receive_within(client) == b"pong"
    finally:
        client.close()
        server.close()


def test_serial_over_a_real_pty() -> None:
    controller, device = os.openpty()
    port = open_transport(f"serial:{os.ttyname(device)}:115200")
    try:
        os.write(controller, b"\xfdradio")
        assert receive_within(port) == b"\xfdradio"
        port.send(b"reply")
        time.sleep(0.05)
        assert os.read(controller, 64) == b"reply"
    finally:
        port.close()
        os.close(controller)
        os.close(device)


@pytest.mark.parametrize(
    "address, fragment",
    [
        ("localhost", "expected udp:HOST:PORT"),
        ("udp:127.0.0.1", "expected HOST:PORT"),
        ("udp:127.0.0.1:99999", "port 99999 is not a port number"),
        ("tcp:127.0.0.1:0", "port 0 is not a port number"),
        ("carrier-pigeon:x:1", "unknown scheme"),
        ("serial:/dev/does-not-exist:57600", "cannot open serial port"),
        ("serial:/dev/ttyS0:fast", "baud rate must be a number"),
    ],
)
def test_bad_addresses_raise_one_clear_line(address: str, fragment: str) -> None:
    with pytest.raises(AddressError) as err:
        open_transport(address)
    assert fragment in str(err.value)
    assert "\n" not in str(err.value)


def test_port_in_use_is_an_address_error() -> None:
    port = free_port()
    first = open_transport(f"tcp:127.0.0.1:{port}", listen=True)
    try:
        with pytest.raises(AddressError, match="cannot open"):
            open_transport(f"tcp:127.0.0.1:{port}", listen=True)
    finally:
        first.close()


def test_udp_port_in_use_is_an_address_error() -> None:
    port = free_port()
    first = open_transport(f"udp:127.0.0.1:{port}", listen=True)
    try:
        with pytest.raises(AddressError, match="cannot open"):
            open_transport(f"udp:127.0.0.1:{port}", listen=True)
    finally:
        first.close()
