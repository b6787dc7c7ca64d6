"""`vil modem`'s edge: the emulator's core on a serial line in real time.

A new pseudo-terminal (os.openpty, raw, 8 bits) or an existing serial device (pyserial) is served:
bytes read are handed to the core with their arrival time (time.monotonic from the start), the core
is advanced to each instant it asks for (`next_due_s`: a command's 2 ms gap, a reception's end, a
ping's 4 s) and what it writes goes out. The first line printed is the device's path alone; a host
that does not read its replies does not stall the emulator: what cannot be written is dropped and
counted (`host_not_reading`). With a sea port (`--sea`), simulated remote units send and move by
datagram and hear their frames back (`acoustic.nanomodem.sea`). SIGINT/SIGTERM end it (0), a device
that vanishes too (1, one line); either way the counts go to stderr.
"""

from __future__ import annotations

import os
import select
import signal
import socket
import sys
import termios
import time
import tty
from collections.abc import Callable
from types import FrameType
from typing import TextIO

import numpy as np
import serial

from acoustic.nanomodem.emulator import Frame, ModemEmulator
from acoustic.nanomodem.ports import BAUD
from acoustic.nanomodem.sea import MAX_DATAGRAM, HeardFrame, Move, Power, SeaError, Send, encode, parse

MAX_IDLE_S = 0.5  # the loop wakes at least this often (to see a stop request)


class Vanished(Exception):
    """The served device has gone."""


class _Line:
    """The served end: a pty's master, or a serial device."""

    def __init__(self, device: str | None) -> None:
        self._serial: serial.Serial | None = None
        if device is None:
            self.fd, self._slave = os.openpty()
            tty.setraw(self._slave)  # 8 bits through, no echo, no CR/LF translation
            attrs = termios.tcgetattr(self._slave)
            attrs[4] = attrs[5] = termios.B9600
            termios.tcsetattr(self._slave, termios.TCSANOW, attrs)
            self.name = os.ttyname(self._slave)  # we keep the slave open: a client's close is no EOF
        else:
            self._serial = serial.serial_for_url(device, baudrate=BAUD, bytesize=8, parity="N", stopbits=1,
                                                 timeout=0)
            self.fd, self.name = self._serial.fileno(), device
        os.set_blocking(self.fd, False)

    def read(self) -> bytes:
        """What has arrived; `Vanished` if the device has gone (EIO: unplugged, its pty closed)."""
        try:
            data = os.read(self.fd, 4096)
        except BlockingIOError:
            return b""
        except OSError as exc:
            raise Vanished(f"{self.name}: gone ({exc.strerror})") from None
        if not data:
            raise Vanished(f"{self.name}: gone (end of file)")
        return data

    def write(self, data: bytes) -> int:
        """Bytes written (a host that does not read fills the buffer: the rest is for the caller to count)."""
        try:
            return os.write(self.fd, data)
        except BlockingIOError:
            return 0
        except OSError as exc:
            raise Vanished(f"{self.name}: gone ({exc.strerror})") from None

    def close(self) -> None:
        if self._serial is not None:
            self._serial.close()
        else:
            os.close(self.fd)
            os.close(self._slave)


class _SeaPort:
    """`--sea udp:HOST:PORT`: simulated remote units send and move through datagrams
    (`acoustic.nanomodem.sea`); what they hear goes back to the last client heard from."""

    def __init__(self, host: str, port: int, core: ModemEmulator) -> None:
        self.core = core
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind((host, port))
        self.sock.setblocking(False)
        self.fd = self.sock.fileno()
        self.client: tuple[str, int] | None = None
        core.on_remote_heard = self._heard

    def read(self, now_s: float) -> None:
        for _ in range(256):  # bounded per wake: a flood waits for the next
            try:
                datagram, peer = self.sock.recvfrom(MAX_DATAGRAM)
            except (BlockingIOError, InterruptedError):
                return
            try:
                item = parse(datagram)
            except SeaError as exc:
                self._count(f"sea_{exc.reason}")
                continue
            self.client = peer
            try:
                if isinstance(item, Send):
                    self.core.remote_send(item.address, now_s, item.data, item.dest)
                elif isinstance(item, Move):
                    self.core.move_remotes(list(item.positions), np.array(list(item.positions.values())))
                elif isinstance(item, Power):
                    self.core.set_power(item.powered)
                else:
                    self._count("sea_not_a_command")
            except (KeyError, ValueError):  # a unit this sea does not have; a payload the modem cannot send
                self._count("sea_unknown_unit_or_payload")

    def _heard(self, _t_s: float, address: int, frame: Frame) -> None:
        if self.client is None:
            self._count("sea_no_client")
            return
        try:
            self.sock.sendto(encode(HeardFrame(address, frame.kind, frame.data)), self.client)
        except OSError:
            self._count("sea_client_gone")

    def _count(self, reason: str) -> None:
        self.core.counts[reason] = self.core.counts.get(reason, 0) + 1

    def close(self) -> None:
        self.sock.close()


def serve(core: ModemEmulator, device: str | None, out: TextIO, describe: str = "",
          monotonic: Callable[[], float] = time.monotonic, sea: tuple[str, int] | None = None) -> int:
    """Serve until SIGINT/SIGTERM (0) or the device vanishes (1, one line); the first line on `out` is
    the device's path. `sea`: also listen there for simulated remote units (`_SeaPort`)."""
    line = _Line(device)
    sea_port = _SeaPort(sea[0], sea[1], core) if sea is not None else None
    stop: list[int] = []

    def on_signal(signum: int, _frame: FrameType | None) -> None:
        stop.append(signum)

    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, on_signal)
    print(line.name, file=out, flush=True)
    if describe:
        print(describe, file=out, flush=True)
    t0 = monotonic()
    code = 0
    try:
        while not stop:
            now = monotonic() - t0
            due = core.next_due_s()
            wait_s = MAX_IDLE_S if due is None else min(max(due - now, 0.0), MAX_IDLE_S)
            try:
                readable, _, _ = select.select([line.fd] + ([sea_port.fd] if sea_port else []), [], [], wait_s)
            except InterruptedError:
                continue
            now = monotonic() - t0
            written = core.advance(now)
            if sea_port is not None and sea_port.fd in readable:
                sea_port.read(now)
                written += core.advance(now)
            if line.fd in readable:
                data = line.read()
                if data:
                    core.from_host(data, now)
                    written += core.advance(now)
            if written:
                sent = line.write(written)
                if sent < len(written):
                    core.counts["host_not_reading"] = core.counts.get("host_not_reading", 0) + len(written) - sent
    except Vanished as exc:
        print(f"vil modem: {exc}", file=sys.stderr, flush=True)
        code = 1
    finally:
        line.close()
        if sea_port is not None:
            sea_port.close()
    counts = ", ".join(f"{k} {v}" for k, v in sorted({**core.counts, **core.medium.counts}.items()) if v)
    print(f"vil modem: stopped; {counts or 'nothing happened'}", file=sys.stderr, flush=True)
    return code
