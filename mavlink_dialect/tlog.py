"""The .tlog format every MAVLink tool reads (mavlogdump, MAVProxy, MAVExplorer): per frame an
8-byte big-endian timestamp in microseconds, then the raw frame. Written by the GCS and the aPad,
read back by replay."""

from __future__ import annotations

import struct
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import BinaryIO

from mavlink_dialect import subcultron as mavlink

_STAMP = struct.Struct(">Q")
_V1_OVERHEAD = 8  # magic, len, seq, sys, comp, msgid, crc16
_V2_OVERHEAD = 12  # magic, len, incompat, compat, seq, sys, comp, msgid24, crc16


class TlogError(ValueError):
    """Not a .tlog (a frame does not start where the previous one ended); one line for the user."""


class TlogWriter:
    """Appends stamped frames; `epoch_us` turns mission time into the stamp (real dates in the field).
    `muted`: frames are dropped, not written (a resumed lockstep mission replaying what the file holds)."""

    def __init__(self, path: Path, epoch_us: int = 0, append: bool = False) -> None:
        self.path = path
        self.epoch_us = epoch_us
        self.muted = False
        self._file: BinaryIO = path.open("ab" if append else "wb")

    def write(self, time_us: int, frame: bytes) -> None:
        if not self.muted:
            self._file.write(_STAMP.pack(self.epoch_us + time_us) + frame)

    def write_many(self, time_us: int, frames: Iterable[bytes]) -> None:
        if not self.muted:
            stamp = _STAMP.pack(self.epoch_us + time_us)
            self._file.write(b"".join(stamp + f for f in frames))

    def size(self) -> int:
        """Bytes in the file, everything written flushed first (closed: as it was left)."""
        if self._file.closed:
            return self.path.stat().st_size
        self._file.flush()
        return self._file.tell()

    def flush(self) -> None:
        self._file.flush()

    def close(self) -> None:
        if not self._file.closed:
            self._file.close()


def frames(path: Path) -> Iterator[tuple[int, bytes]]:
    """(stamp_us, frame) per record; `TlogError` where the file stops being a .tlog."""
    data = path.read_bytes()
    i = 0
    while i + 10 <= len(data):
        (stamp,) = _STAMP.unpack_from(data, i)
        magic, length = data[i + 8], data[i + 9]
        if magic == mavlink.PROTOCOL_MARKER_V2:
            signed = data[i + 10] & mavlink.MAVLINK_IFLAG_SIGNED if i + 10 < len(data) else 0
            size = _V2_OVERHEAD + length + (mavlink.MAVLINK_SIGNATURE_BLOCK_LEN if signed else 0)
        elif magic == mavlink.PROTOCOL_MARKER_V1:
            size = _V1_OVERHEAD + length
        else:
            raise TlogError(f"{path}: not a MAVLink .tlog (bad frame at byte {i + 8})")
        yield stamp, data[i + 8 : i + 8 + size]
        i += 8 + size


def first_stamp_us(path: Path) -> int | None:
    """The first record's stamp (the log's clock at its start), reading 8 bytes; None if the log is empty."""
    with path.open("rb") as f:
        head = f.read(_STAMP.size)
    return _STAMP.unpack(head)[0] if len(head) == _STAMP.size else None
