"""The water's other side: how simulated remote units (the aMussels' modems) reach the emulator's medium.

A `Sea` is what `mussel_sim.modems` speaks to: a remote unit sends, the remote units move or lose or
regain power, and what a remote unit hears addressed to it (or to all) comes back. Two implementations:

- in lockstep, `acoustic.nanomodem.lockstep.Attached` (the emulator in-process, on the mission clock);
- beside a unit on a serial port, `SeaClient` here: datagrams to `vil modem --sea udp:HOST:PORT`, whose
  emulator holds the medium that the GCS's serial unit transmits into (`vil gcs --modem DEV --sea ADDR`).

The datagrams are ASCII lines (one command per datagram), each field separated by one space:

    S <address> <dest|*> <hex data>        remote unit <address> sends (to <dest>, or to all)
    M <address> <x> <y> <z> [...]          remote units' positions, metres from the served unit (x east,
                                           y north, z down); several units in one datagram
    P <address> <0|1> [...]                remote units' power (0: none, it hears and answers nothing)
    H <address> <kind> <hex data>          (emulator to client) remote unit <address> heard a frame

`parse` refuses anything else with a `SeaError` naming the reason (the receiver counts it).
"""

from __future__ import annotations

import math
import socket
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from acoustic.nanomodem.emulator import FrameKind
from acoustic.nanomodem.host_commands import MAX_ADDRESS

MAX_DATAGRAM = 8192
MAX_POSITION_M = 1e6

Heard = Callable[[int, FrameKind, bytes], None]  # (remote unit's address, what kind of frame, its data)


class Sea(Protocol):
    def send(self, address: int, data: bytes, dest: int | None) -> None: ...

    def move(self, addresses: list[int], positions_m: NDArray[np.float64]) -> None: ...

    def power(self, powered: dict[int, bool]) -> None: ...

    def listen(self, heard: Heard) -> None: ...


class SeaError(ValueError):
    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


@dataclass(frozen=True)
class Send:
    address: int
    dest: int | None
    data: bytes


@dataclass(frozen=True)
class Move:
    positions: dict[int, tuple[float, float, float]]


@dataclass(frozen=True)
class Power:
    powered: dict[int, bool]


@dataclass(frozen=True)
class HeardFrame:
    address: int
    kind: FrameKind
    data: bytes


KINDS = {k.value: k for k in FrameKind}


def _address(text: str) -> int:
    if not text.isdigit() or int(text) > MAX_ADDRESS:
        raise SeaError("address")
    return int(text)


def _hex(text: str) -> bytes:
    try:
        return bytes.fromhex(text)
    except ValueError:
        raise SeaError("hex") from None


def parse(datagram: bytes) -> Send | Move | Power | HeardFrame:
    """One datagram's command; `SeaError` with the reason if it is none."""
    try:
        fields = datagram.decode("ascii").split(" ")
    except UnicodeDecodeError:
        raise SeaError("not_ascii") from None
    match fields:
        case ["S", address, dest, data]:
            return Send(_address(address), None if dest == "*" else _address(dest), _hex(data))
        case ["H", address, kind, data]:
            if kind not in KINDS:
                raise SeaError("kind")
            return HeardFrame(_address(address), KINDS[kind], _hex(data))
        case ["M", *rest] if rest and len(rest) % 4 == 0:
            positions = {}
            for k in range(0, len(rest), 4):
                try:
                    xyz = tuple(float(v) for v in rest[k + 1:k + 4])
                except ValueError:
                    raise SeaError("position") from None
                if not all(math.isfinite(v) and abs(v) <= MAX_POSITION_M for v in xyz):
                    raise SeaError("position")
                positions[_address(rest[k])] = (xyz[0], xyz[1], xyz[2])
            return Move(positions)
        case ["P", *rest] if rest and len(rest) % 2 == 0:
            powered = {}
            for k in range(0, len(rest), 2):
                if rest[k + 1] not in ("0", "1"):
                    raise SeaError("power")
                powered[_address(rest[k])] = rest[k + 1] == "1"
            return Power(powered)
    raise SeaError("command")


def encode(item: Send | Move | Power | HeardFrame) -> bytes:
    match item:
        case Send():
            dest = "*" if item.dest is None else str(item.dest)
            return f"S {item.address} {dest} {item.data.hex() or ''}".encode()
        case HeardFrame():
            return f"H {item.address} {item.kind.value} {item.data.hex()}".encode()
        case Move():
            return ("M " + " ".join(f"{a} {x:.3f} {y:.3f} {z:.3f}" for a, (x, y, z) in item.positions.items())).encode()
        case Power():
            return ("P " + " ".join(f"{a} {int(on)}" for a, on in item.powered.items())).encode()


class SeaClient:
    """A `Sea` over UDP to `vil modem --sea`: sends at once; what the remote units heard is read as a
    poller of the mission scheduler (its socket's fileno), malformed datagrams counted by reason."""

    def __init__(self, host: str, port: int) -> None:
        self.address = (host, port)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setblocking(False)
        self.sock.connect(self.address)
        self.dropped: Counter[str] = Counter()
        self.sent = 0
        self._heard: Heard | None = None

    def send(self, address: int, data: bytes, dest: int | None) -> None:
        self._out(encode(Send(address, dest, data)))

    def move(self, addresses: list[int], positions_m: NDArray[np.float64]) -> None:
        # A datagram per 100 units keeps each under MAX_DATAGRAM.
        for k in range(0, len(addresses), 100):
            chunk = {a: (float(p[0]), float(p[1]), float(p[2]))
                     for a, p in zip(addresses[k:k + 100], positions_m[k:k + 100], strict=True)}
            self._out(encode(Move(chunk)))

    def power(self, powered: dict[int, bool]) -> None:
        items = list(powered.items())
        for k in range(0, len(items), 100):  # a datagram per 100 units, as `move`
            self._out(encode(Power(dict(items[k:k + 100]))))

    def listen(self, heard: Heard) -> None:
        self._heard = heard

    def _out(self, datagram: bytes) -> None:
        try:
            self.sock.send(datagram)
            self.sent += 1
        except OSError as exc:  # the emulator not (yet) there: the packet is lost on the water, counted
            self.dropped[f"send:{type(exc).__name__}"] += 1

    # ---- a scheduler poller
    def fileno(self) -> int | None:
        return self.sock.fileno()

    def poll(self) -> bool:
        got = False
        for _ in range(256):  # bounded per poll: a flood waits for the next
            try:
                datagram = self.sock.recv(MAX_DATAGRAM)
            except (BlockingIOError, InterruptedError):
                break
            except OSError as exc:  # e.g. ECONNREFUSED from an earlier send: nobody listening yet
                self.dropped[f"recv:{type(exc).__name__}"] += 1
                break
            got = True
            try:
                item = parse(datagram)
            except SeaError as exc:
                self.dropped[exc.reason] += 1
                continue
            if not isinstance(item, HeardFrame):
                self.dropped["not_heard"] += 1
            elif self._heard is not None:
                self._heard(item.address, item.kind, item.data)
        return got

    def close(self) -> None:
        self.sock.close()


class SilentSea:
    """No water for the simulated aMussels (`vil gcs --modem` without `--sea`): what they would send is
    counted, and they hear nothing; only the units really on the water are heard."""

    def __init__(self) -> None:
        self.dropped: Counter[str] = Counter()

    def send(self, address: int, data: bytes, dest: int | None) -> None:
        self.dropped["no_sea"] += 1

    def move(self, addresses: list[int], positions_m: NDArray[np.float64]) -> None:
        pass

    def power(self, powered: dict[int, bool]) -> None:
        pass

    def listen(self, heard: Heard) -> None:
        pass


def parse_udp(address: str) -> tuple[str, int]:
    """`udp:HOST:PORT` as (host, port); ValueError (one line) otherwise."""
    parts = address.split(":")
    if len(parts) != 3 or parts[0] != "udp" or not parts[2].isdigit() or not 0 < int(parts[2]) < 65536:
        raise ValueError(f"{address!r} is not udp:HOST:PORT")
    return parts[1] or "127.0.0.1", int(parts[2])
