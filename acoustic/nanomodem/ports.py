"""Byte ports the driver speaks through: a serial device (pyserial: a real unit, a pty, any URL
`serial.serial_for_url` opens) or one end of an in-process pipe (lockstep runs, no pty).

Both are non-blocking: `read` returns what has arrived (b"" if nothing); waiting is the driver's,
on its clock. A port that has gone (unplugged, closed) raises `PortClosed` from then on.
"""

from __future__ import annotations

from collections import deque
from typing import Protocol

import serial

from missiontime.clocks import Doorbell

BAUD = 9600  # 8N1, no flow control


class PortClosed(Exception):
    """The device is gone."""


class BytePort(Protocol):
    def write(self, data: bytes) -> None: ...

    def read(self) -> bytes: ...

    def close(self) -> None: ...


class SerialPort:
    """A serial device at 9600 8N1 (a path such as /dev/ttyUSB0 or /dev/pts/5, or a pyserial URL)."""

    def __init__(self, url: str) -> None:
        try:
            self._serial = serial.serial_for_url(url, baudrate=BAUD, bytesize=8, parity="N", stopbits=1,
                                                 timeout=0, write_timeout=2.0)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise PortClosed(f"{url}: cannot open: {exc}") from None
        self.url = url

    def write(self, data: bytes) -> None:
        try:
            self._serial.write(data)
            self._serial.flush()
        except (serial.SerialException, OSError, ValueError) as exc:
            raise PortClosed(f"{self.url}: {exc}") from None

    def read(self) -> bytes:
        try:
            waiting = self._serial.in_waiting
            return bytes(self._serial.read(waiting or 1))
        except (serial.SerialException, OSError, ValueError, TypeError) as exc:
            # pyserial raises TypeError from a port closed under it (its fd became None)
            raise PortClosed(f"{self.url}: {exc}") from None

    def close(self) -> None:
        self._serial.close()


class PipeEnd:
    """One end of an in-process byte pipe; `pipe()` makes the pair. An end given a `bell` (a mission
    scheduler's `Doorbell`) has it rung by every write into it: the scheduler polls its reader only then."""

    def __init__(self) -> None:
        self._inbox: deque[bytes] = deque()
        self.peer: PipeEnd | None = None
        self.closed = False
        self.bell: Doorbell | None = None

    def write(self, data: bytes) -> None:
        if self.closed or self.peer is None or self.peer.closed:
            raise PortClosed("pipe closed")
        self.peer._inbox.append(bytes(data))  # noqa: SLF001 - the pair is one object in two halves
        if self.peer.bell is not None:
            self.peer.bell.rings += 1

    @property
    def waiting(self) -> bool:
        """Whether bytes wait to be read (or the other end has closed: a read would say so)."""
        return bool(self._inbox) or (self.peer is not None and self.peer.closed)

    def read(self) -> bytes:
        if self.closed:
            raise PortClosed("pipe closed")
        data = b"".join(self._inbox)
        self._inbox.clear()
        if not data and self.peer is not None and self.peer.closed:
            raise PortClosed("pipe closed by the other end")
        return data

    def close(self) -> None:
        self.closed = True


def pipe() -> tuple[PipeEnd, PipeEnd]:
    a, b = PipeEnd(), PipeEnd()
    a.peer, b.peer = b, a
    return a, b
