"""Byte transports shared by every MAVLink party: UDP, TCP, serial and an in-memory pair.

A transport moves opaque bytes; framing and parsing belong to `Codec`. All reads are
non-blocking (`receive()` returns what has arrived); a real-time loop waits on `fileno()`
with `select`, a lockstep loop simply polls.

Address strings name the medium; whether we listen or connect is the caller's choice:

    udp:HOST:PORT        udpin:/udpout: are accepted too (pymavlink's spelling)
    tcp:HOST:PORT        tcpin: listens
    serial:DEVICE[:BAUD] e.g. serial:/dev/ttyUSB0:57600

Exposure (issue 10): a listener binds only the HOST it is given (the defaults are 127.0.0.1); a
connecting UDP socket binds the one interface that routes to its peer (loopback for a local
peer), never 0.0.0.0. Everything that grows with received traffic has a documented bound, and
what a bound turns away is counted by reason in the transport's `dropped`:

    MAX_RECEIVE_BATCH  datagrams (or stream reads) per `receive()`; the rest waits in the kernel
    MAX_PEERS          UDP peers a listener answers; a peer silent for PEER_TIMEOUT_S is forgotten
    MAX_CLIENTS        TCP clients a listener keeps
    MAX_INBOX          datagrams queued in an in-memory end
"""

from __future__ import annotations

import contextlib
import ipaddress
import socket
import time
from collections import Counter, deque
from collections.abc import Callable
from typing import Protocol

MAX_DATAGRAM = 65535
MAX_RECEIVE_BATCH = 1024  # a flood cannot keep one `receive()` going forever; pollers come back
MAX_PEERS = 8  # a vehicle serves a GCS or two and a few tools, not a crowd
PEER_TIMEOUT_S = 30.0  # a UDP peer silent this long stops getting our frames
MAX_CLIENTS = 8
MAX_INBOX = 65_536  # in-memory datagrams not yet received; a lockstep instant queues a few hundred


class AddressError(ValueError):
    """A transport address that cannot be parsed or opened; the message is one line for the user."""


class Transport(Protocol):
    label: str
    # True: each `receive()` item is one whole datagram as sent (UDP, in-memory), so frames never
    # straddle two items; False: a byte stream (TCP, serial) cut anywhere.
    datagrams: bool

    def send(self, data: bytes) -> None: ...

    def receive(self) -> list[bytes]: ...

    def fileno(self) -> int | None: ...

    def close(self) -> None: ...


class Bell(Protocol):
    """What an in-memory end rings on each delivery (`missiontime.Doorbell`)."""

    rings: int


class MemoryTransport:
    """One end of an in-memory pair; `send` appends to the peer's inbox. Used in lockstep."""

    datagrams = True

    def __init__(self, label: str, max_inbox: int = MAX_INBOX) -> None:
        self.label = label
        self.inbox: deque[bytes] = deque()
        self.max_inbox = max_inbox
        self.peer: MemoryTransport | None = None
        self.closed = False
        self.dropped: Counter[str] = Counter()  # datagrams this end never received, by reason
        self.bell: Bell | None = None  # rung on every delivery into `inbox` (see `ring_on`)

    def send(self, data: bytes) -> None:
        peer = self.peer
        if peer is not None and not peer.closed and not self.closed:
            if len(peer.inbox) >= peer.max_inbox:
                peer.dropped["inbox_full"] += 1
                return
            peer.inbox.append(bytes(data))
            if peer.bell is not None:
                peer.bell.rings += 1

    def receive(self) -> list[bytes]:
        if not self.inbox:  # the common case in a lockstep drain: return without copying
            return []
        out = list(self.inbox)
        self.inbox.clear()
        return out

    def fileno(self) -> int | None:
        return None

    def close(self) -> None:
        self.closed = True


def ring_on(transport: Transport, bell: Bell) -> bool:
    """Have `transport` ring `bell` on every delivery into it; True if nothing reaches it otherwise (an
    in-memory end whose peer is one too, no subclass that might fill the inbox its own way)."""
    if type(transport) is MemoryTransport and type(transport.peer) is MemoryTransport:
        transport.bell = bell
        return True
    return False


def memory_pair(label: str = "mem") -> tuple[MemoryTransport, MemoryTransport]:
    a, b = MemoryTransport(f"{label}:a"), MemoryTransport(f"{label}:b")
    a.peer, b.peer = b, a
    return a, b


class UdpTransport:
    """UDP. Listening: answer every peer heard in the last PEER_TIMEOUT_S (several GCSs may share a
    vehicle), at most MAX_PEERS. Connecting: send to the given host:port only, and accept replies
    from anywhere on the interface bound.

    `now_s` is the clock peers age by (monotonic seconds; a lockstep owner passes mission time).
    """

    datagrams = True

    def __init__(self, host: str, port: int, listen: bool, now_s: Callable[[], float] = time.monotonic,
                 max_peers: int = MAX_PEERS, peer_timeout_s: float = PEER_TIMEOUT_S) -> None:
        self.label = f"udp:{host}:{port}"
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._now_s, self.max_peers, self.peer_timeout_s = now_s, max_peers, peer_timeout_s
        self.heard: dict[tuple[str, int], float] = {}  # learnt peers (listening) -> when last heard
        self.fixed: tuple[str, int] | None = None if listen else (host, port)  # the peer we connect to
        self.dropped: Counter[str] = Counter()  # datagrams refused by a bound, by reason
        self.pruned = 0  # peers forgotten after PEER_TIMEOUT_S of silence
        self.max_batch = MAX_RECEIVE_BATCH
        try:
            self.sock.bind((host, port) if listen else (local_address_towards(host, port), 0))
        except OSError:
            self.sock.close()
            raise
        self.sock.setblocking(False)

    @property
    def local_port(self) -> int:
        return int(self.sock.getsockname()[1])

    @property
    def local_host(self) -> str:
        return str(self.sock.getsockname()[0])

    @property
    def peers(self) -> list[tuple[str, int]]:
        """Who `send` reaches: the fixed peer, or the peers heard lately (silent ones pruned)."""
        if self.fixed is not None:
            return [self.fixed]
        self._prune(self._now_s())
        return list(self.heard)

    def _prune(self, now: float) -> None:
        stale = [addr for addr, t in self.heard.items() if now - t > self.peer_timeout_s]
        for addr in stale:
            del self.heard[addr]
        self.pruned += len(stale)

    def send(self, data: bytes) -> None:
        for peer in self.peers:
            # A peer that went away (ICMP unreachable) must not stop the loop.
            with contextlib.suppress(OSError):
                self.sock.sendto(data, peer)

    def receive(self) -> list[bytes]:
        out: list[bytes] = []
        now = self._now_s()
        self._prune(now)
        while len(out) < self.max_batch:
            try:
                data, addr = self.sock.recvfrom(MAX_DATAGRAM)
            except (BlockingIOError, InterruptedError):
                return out
            except OSError:  # ECONNREFUSED surfaced from an earlier send
                continue
            if self.fixed is None:
                if addr not in self.heard and len(self.heard) >= self.max_peers:
                    self.dropped["peer_limit"] += 1  # the peers we serve keep their place
                    continue
                self.heard[addr] = now
            out.append(data)
        return out

    def fileno(self) -> int | None:
        return self.sock.fileno()

    def close(self) -> None:
        self.sock.close()


def local_address_towards(host: str, port: int) -> str:
    """The local address a datagram to host:port leaves from: 127.0.0.1 for a loopback peer, else
    the one interface the route uses (a UDP `connect` sends nothing; it only asks the kernel)."""
    try:
        if ipaddress.ip_address(host).is_loopback:
            return "127.0.0.1"
    except ValueError:
        pass  # a name: ask the kernel
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.connect((host, port))
        return str(probe.getsockname()[0])


class TcpTransport:
    """TCP. Connecting: one stream to host:port. Listening: accept clients, send to all."""

    datagrams = False

    def __init__(self, host: str, port: int, listen: bool) -> None:
        self.label = f"tcp:{host}:{port}"
        self.server: socket.socket | None = None
        self.clients: list[socket.socket] = []
        self.dropped: Counter[str] = Counter()  # connections refused by a bound, by reason
        if listen:
            server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            try:
                server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
                server.bind((host, port))
                server.listen(4)
            except OSError:
                server.close()
                raise
            server.setblocking(False)
            self.server = server
        else:
            conn = socket.create_connection((host, port), timeout=5.0)
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            conn.setblocking(False)
            self.clients.append(conn)

    def _accept(self) -> None:
        while self.server is not None:
            try:
                conn, _ = self.server.accept()
            except (BlockingIOError, InterruptedError):
                return
            if len(self.clients) >= MAX_CLIENTS:
                conn.close()
                self.dropped["client_limit"] += 1
                continue
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            conn.setblocking(False)
            self.clients.append(conn)

    def send(self, data: bytes) -> None:
        for conn in list(self.clients):
            try:
                conn.sendall(data)
            except BlockingIOError:
                pass  # a peer too slow to keep up loses this frame, like a radio would
            except OSError:
                self._drop(conn)

    def receive(self) -> list[bytes]:
        self._accept()
        out = []
        for conn in list(self.clients):
            for _ in range(MAX_RECEIVE_BATCH // MAX_CLIENTS):  # the rest waits in the kernel
                try:
                    data = conn.recv(MAX_DATAGRAM)
                except (BlockingIOError, InterruptedError):
                    break
                except OSError:
                    self._drop(conn)
                    break
                if not data:
                    self._drop(conn)
                    break
                out.append(data)
        return out

    def _drop(self, conn: socket.socket) -> None:
        conn.close()
        if conn in self.clients:
            self.clients.remove(conn)

    def fileno(self) -> int | None:
        if self.server is not None and not self.clients:
            return self.server.fileno()
        return self.clients[0].fileno() if self.clients else None

    def close(self) -> None:
        for conn in self.clients:
            conn.close()
        if self.server is not None:
            self.server.close()


class SerialTransport:
    """A serial port or pty (telemetry radio); pyserial does the line settings."""

    datagrams = False

    def __init__(self, device: str, baud: int) -> None:
        import serial  # pyserial: only needed for this medium

        self.label = f"serial:{device}:{baud}"
        try:
            self.port = serial.Serial(device, baudrate=baud, timeout=0, write_timeout=0)
        except serial.SerialException as exc:
            raise AddressError(f"cannot open serial port {device}: {exc}") from None

    def send(self, data: bytes) -> None:
        import serial

        with contextlib.suppress(serial.SerialTimeoutException):  # buffer full: the radio drops it
            self.port.write(data)

    def receive(self) -> list[bytes]:
        waiting = self.port.in_waiting
        return [self.port.read(waiting)] if waiting else []

    def fileno(self) -> int | None:
        return int(self.port.fileno())

    def close(self) -> None:
        self.port.close()


def _host_port(address: str, rest: str) -> tuple[str, int]:
    host, sep, port = rest.rpartition(":")
    if not sep or not host or not port:
        raise AddressError(f"bad address {address!r}: expected HOST:PORT after the scheme")
    if not port.isdigit() or not 0 < int(port) < 65536:
        raise AddressError(f"bad address {address!r}: port {port} is not a port number (1 to 65535)")
    return host, int(port)


def open_transport(address: str, listen: bool = False) -> Transport:
    """Open the transport an address string names (see the module docstring)."""
    scheme, sep, rest = address.partition(":")
    if not sep:
        raise AddressError(f"bad address {address!r}: expected udp:HOST:PORT, tcp:HOST:PORT or serial:DEVICE[:BAUD]")
    try:
        if scheme in ("udp", "udpin", "udpout"):
            host, port = _host_port(address, rest)
            return UdpTransport(host, port, listen=listen or scheme == "udpin")
        if scheme in ("tcp", "tcpin"):
            host, port = _host_port(address, rest)
            return TcpTransport(host, port, listen=listen or scheme == "tcpin")
        if scheme == "serial":
            device, _, baud = rest.partition(":")
            if baud and not baud.isdigit():
                raise AddressError(f"bad address {address!r}: baud rate must be a number")
            return SerialTransport(device, int(baud) if baud else 57600)
    except OSError as exc:
        raise AddressError(f"cannot open {address}: {exc.strerror or exc}") from None
    raise AddressError(f"bad address {address!r}: unknown scheme {scheme!r} (udp, tcp, serial)")
