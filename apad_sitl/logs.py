"""The aPad's own logs (the paper logs redundantly, on the aPad too): a .tlog and a JSON-lines event log.

The .tlog is pymavlink's format, readable by `mavlogdump.py` and `mavutil.mavlink_connection`:
per message an 8-byte big-endian timestamp in microseconds, then the raw MAVLink frame.
Timestamps are mission time plus `epoch_us` (0 in lockstep; the real-time server passes the
wall-clock epoch at start so the log carries real dates). With signing on, `vil sitl` keeps the
signing timestamps beside them (`signing_path`, see `mavlink_dialect.signing_state`).
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

from mavlink_dialect.tlog import TlogWriter
from missiontime import us_to_s

# The physics flushes the .tlog each second of mission time; in lockstep those come hundreds of times a
# wall second, and a write to the kernel each was a few per cent of a long run. At most this often
# (wall time), then: what a killed process loses is the same quarter of a second in the field and here.
FLUSH_EVERY_WALL_S = 0.25


def tlog_path(log_dir: Path, system_id: int) -> Path:
    """aPad `system_id`'s .tlog in `log_dir` (the aPad names its own logs; a run folder asks it)."""
    return log_dir / f"apad{system_id}.tlog"


def events_path(log_dir: Path, system_id: int) -> Path:
    return log_dir / f"apad{system_id}.events.jsonl"


def signing_path(log_dir: Path, system_id: int) -> Path:
    return log_dir / f"apad{system_id}.signing.json"


class VehicleLog:
    """Both logs of one aPad. `muted`: nothing reaches the files (a resumed lockstep mission
    replaying what they already hold)."""

    def __init__(self, log_dir: Path, system_id: int, epoch_us: int = 0, append: bool = False,
                 tlog: bool = True) -> None:
        """`append` continues existing logs (the mission resumed after a GCS crash); `tlog` False: the event
        log alone (the event platform's ideal link carries no bytes to log)."""
        log_dir.mkdir(parents=True, exist_ok=True)
        self.tlog_path = tlog_path(log_dir, system_id)
        self.events_path = events_path(log_dir, system_id)
        self.signing_path = signing_path(log_dir, system_id)
        self.epoch_us = epoch_us
        self._tlog = TlogWriter(self.tlog_path, epoch_us, append) if tlog else None
        self._events = open(self.events_path, "a" if append else "w", encoding="utf-8")  # noqa: SIM115
        self.muted = False
        self._flushed_at = time.monotonic()

    def message(self, time_us: int, frame: bytes | bytearray) -> None:
        if self._tlog is not None:
            self._tlog.write(time_us, bytes(frame))

    def messages(self, time_us: int, frames: list[bytes]) -> None:
        if self._tlog is not None:
            self._tlog.write_many(time_us, frames)

    def event(self, time_us: int, event: str, **fields: Any) -> None:
        if self.muted:
            return
        record = {"t_s": round(us_to_s(time_us), 6), "event": event, **fields}
        self._events.write(json.dumps(record, separators=(",", ":")) + "\n")
        self._events.flush()  # events are rare and the ones before a crash matter most

    def mute(self, muted: bool) -> None:
        self.muted = muted
        if self._tlog is not None:
            self._tlog.muted = muted

    def sizes(self) -> dict[Path, int]:
        """How long each log is now, everything written flushed first (what a checkpoint keeps)."""
        events = self.events_path.stat().st_size if self._events.closed else self._events.tell()
        return ({} if self._tlog is None else {self.tlog_path: self._tlog.size()}) | {self.events_path: events}

    def flush(self) -> None:
        """Into the kernel, unless that was done less than FLUSH_EVERY_WALL_S ago (wall time)."""
        now = time.monotonic()
        if now - self._flushed_at >= FLUSH_EVERY_WALL_S:
            self._flushed_at = now
            if self._tlog is not None:
                self._tlog.flush()

    def close(self) -> None:
        if self._tlog is not None:
            self._tlog.close()
        if not self._events.closed:
            self._events.close()


