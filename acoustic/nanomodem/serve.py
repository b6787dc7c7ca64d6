"""`vil modem`'s edge: the emulator's core on a serial line in real time.

A new pseudo-terminal (os.openpty, raw, 8 bits) or an existing serial device (pyserial) is served:
bytes read are handed to the core with their arrival time (time.monotonic from the start), the core
is advanced to each instant it asks for (`next_due_s`: a command's 2 ms gap, a reception's end, a
ping's 4 s) and what it writes goes out. The first line printed is the device's path alone; a host
that does not read its replies does not stall the emulator: what cannot be written is dropped and
counted (`host_not_reading`). SIGINT/SIGTERM end it (0), a device that vanishes too (1, one line);
either way the counts go to stderr.
"""

from __future__ import annotations

import os
import select
import signal
import sys
import termios
import time
import tty
from collections.abc import Callable
from types import FrameType
from typing import TextIO

import serial

from acoustic.nanomodem.emulator import ModemEmulator
from acoustic.nanomodem.ports import BAUD

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


def serve(core: ModemEmulator, device: str | None, out: TextIO, describe: str = "",
          monotonic: Callable[[], float] = time.monotonic) -> int:
    """Serve until SIGINT/SIGTERM (0) or the device vanishes (1, one line); the first line on `out` is
    the device's path."""
    line = _Line(device)
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
                readable, _, _ = select.select([line.fd], [], [], wait_s)
            except InterruptedError:
                continue
            now = monotonic() - t0
            written = core.advance(now)
            if readable:
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
    counts = ", ".join(f"{k} {v}" for k, v in sorted({**core.counts, **core.medium.counts}.items()) if v)
    print(f"vil modem: stopped; {counts or 'nothing happened'}", file=sys.stderr, flush=True)
    return code
