"""The aPad's own logs (the paper logs redundantly, on the aPad too): a .tlog and a JSON-lines event log.

The .tlog is pymavlink's format, readable by `mavlogdump.py` and `mavutil.mavlink_connection`:
per message an 8-byte big-endian timestamp in microseconds, then the raw MAVLink frame.
Timestamps are mission time plus `epoch_us` (0 in lockstep; the real-time server passes the
wall-clock epoch at start so the log carries real dates). With signing on, `vil sitl` keeps the
signing timestamps beside them (`signing_path`, see `mavlink_dialect.signing_state`).
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from mavlink_dialect.tlog import TlogWriter
from missiontime import seconds_to_us, us_to_s

EVENTS_SUFFIX = ".events.jsonl"


class VehicleLog:
    def __init__(self, log_dir: Path, stem: str, epoch_us: int = 0, append: bool = False) -> None:
        """`append` continues existing logs (the mission resumed after a GCS crash)."""
        log_dir.mkdir(parents=True, exist_ok=True)
        self.tlog_path = log_dir / f"{stem}.tlog"
        self.events_path = log_dir / f"{stem}{EVENTS_SUFFIX}"
        self.signing_path = log_dir / f"{stem}.signing.json"
        self.epoch_us = epoch_us
        self._tlog = TlogWriter(self.tlog_path, epoch_us, append)
        self._events = open(self.events_path, "a" if append else "w", encoding="utf-8")  # noqa: SIM115

    def message(self, time_us: int, frame: bytes | bytearray) -> None:
        self._tlog.write(time_us, bytes(frame))

    def messages(self, time_us: int, frames: list[bytes]) -> None:
        self._tlog.write_many(time_us, frames)

    def event(self, time_us: int, event: str, **fields: Any) -> None:
        record = {"t_s": round(us_to_s(time_us), 6), "event": event, **fields}
        self._events.write(json.dumps(record, separators=(",", ":")) + "\n")
        self._events.flush()  # events are rare and the ones before a crash matter most

    def flush(self) -> None:
        self._tlog.flush()

    def close(self) -> None:
        self._tlog.close()
        if not self._events.closed:
            self._events.close()


def event_records(path: Path) -> Iterator[tuple[int, int, bool]]:
    """Each line of an aPad event log as (mission time in us, its length in bytes, whether it is whole):
    what `gcs.records.checkpoint.cut_logs` needs to cut the log back to a checkpoint. A line a crash
    cut short (no newline, or not a record) is not whole; nothing is read past it."""
    with path.open("rb") as f:
        for line in f:
            try:
                record = json.loads(line) if line.endswith(b"\n") else None
                t_us = seconds_to_us(float(record["t_s"])) if isinstance(record, dict) else None
            except (ValueError, KeyError, TypeError):
                t_us = None
            yield (t_us or 0, len(line), t_us is not None)
            if t_us is None:
                return
