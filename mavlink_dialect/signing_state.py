"""Signing timestamps kept across restarts, as ArduPilot keeps its signing timestamp in storage.

Without them a restarted receiver knows no stream, and MAVLink lets a stream it has never seen
start up to 60 s behind its clock: every signed frame recorded in the minute before a restart
could be played back after it. `SigningKeeper` saves the codec's per-stream timestamps, the floor
for unknown streams and its own signing clock to a small JSON file (temp file, then `os.replace`,
so a crash leaves the old file or the new one, never half of one), at most once per
`SAVE_PERIOD_S` and at close, and restores them at start.

A frame accepted after the last save and before a crash (kill -9, power loss) is not in the file.
So a restart adds `RESTART_MARGIN_TICKS` (more than a save period) to every stored timestamp: a
stream must then be that much newer than what was saved. The cost: after a restart quicker than
the margin, a GCS's first frames are refused until its clock passes the margin (its retries
cover that). The own clock gets the margin too, so what we sign never goes backwards.

A damaged file (unreadable, not our JSON, out-of-range values, too large) does not stop the
vehicle: it starts afresh with its clock at now and refuses every stream stamped at or before
now, so nothing recorded before the restart can be replayed; a GCS whose clock is behind ours is
refused until it catches up. `SigningKeeper.start` returns the one line that says so.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mavlink_dialect.signing import MAX_STREAMS, TICKS_PER_S

FORMAT = 1
SAVE_PERIOD_S = 1.0
RESTART_MARGIN_TICKS = 2 * TICKS_PER_S  # > SAVE_PERIOD_S: covers what was accepted after the last save
MAX_FILE_BYTES = 16 * 1024  # MAX_STREAMS entries take ~2 KiB; anything bigger is not ours
MAX_TICKS = 2**48 - 1  # the signature's timestamp field is 48 bits

Stream = tuple[int, int, int]  # link id, system id, component id


class SigningStateError(ValueError):
    """A signing-state file that cannot be used; the message is one line."""


@dataclass(frozen=True)
class SigningState:
    timestamp: int  # our signing clock, MAVLink ticks
    floor: int = 0  # unknown streams must stamp above this
    streams: dict[Stream, int] = field(default_factory=dict)

    @classmethod
    def of(cls, mav: Any) -> SigningState:
        s = mav.signing
        newest = sorted(s.stream_timestamps.items(), key=lambda kv: kv[1], reverse=True)[:MAX_STREAMS]
        return cls(int(s.timestamp), int(s.stream_floor), {k: int(v) for k, v in newest})

    def to_json(self) -> str:
        streams = [[*k, v] for k, v in sorted(self.streams.items())]
        return json.dumps({"format": FORMAT, "timestamp": self.timestamp, "floor": self.floor, "streams": streams})


def _ticks(value: object, what: str) -> int:
    if type(value) is not int or not 0 <= value <= MAX_TICKS:
        raise SigningStateError(f"{what} is not a 48-bit timestamp")
    return value


def _stream(entry: object) -> tuple[Stream, int]:
    if not (isinstance(entry, list) and len(entry) == 4 and all(type(x) is int for x in entry[:3])
            and all(0 <= x <= 255 for x in entry[:3])):
        raise SigningStateError("a stream is not [link, system, component, timestamp]")
    link, system, component, ts = entry
    return (link, system, component), _ticks(ts, "a stream's timestamp")


def load(path: Path) -> SigningState | None:
    """The state saved at `path`; None if there is no file. SigningStateError if it is damaged."""
    try:
        with path.open("rb") as f:
            raw = f.read(MAX_FILE_BYTES + 1)
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise SigningStateError(f"cannot read {path}: {exc.strerror or exc}") from None
    if len(raw) > MAX_FILE_BYTES:
        raise SigningStateError(f"{path} is larger than {MAX_FILE_BYTES} bytes")
    try:
        obj = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError):
        raise SigningStateError(f"{path} is not JSON") from None
    if not isinstance(obj, dict) or obj.get("format") != FORMAT or not isinstance(obj.get("streams"), list):
        raise SigningStateError(f"{path} is not a signing-state file of format {FORMAT}")
    if len(obj["streams"]) > MAX_STREAMS:
        raise SigningStateError(f"{path} has more than {MAX_STREAMS} streams")
    try:
        streams = dict(_stream(e) for e in obj["streams"])
        return SigningState(_ticks(obj.get("timestamp"), "timestamp"), _ticks(obj.get("floor", 0), "floor"), streams)
    except SigningStateError as exc:
        raise SigningStateError(f"{path}: {exc}") from None


def save(path: Path, state: SigningState) -> None:
    """Write `state` atomically: a temp file beside it, flushed to disk, then `os.replace`."""
    tmp = path.with_name(path.name + ".tmp")
    with tmp.open("w", encoding="utf-8") as f:
        f.write(state.to_json())
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


class SigningKeeper:
    """Restores one signing codec's timestamps at start and saves them while it runs."""

    def __init__(self, path: Path, mav: Any, now_ticks: Callable[[], int]) -> None:
        """`mav` is the codec's pymavlink object, signing already configured; `now_ticks` our clock."""
        self.path, self.mav, self.now_ticks = path, mav, now_ticks
        self.save_errors = 0
        self._saved: SigningState | None = None

    def start(self) -> str | None:
        """Restore what was saved; a one-line notice if the file was damaged (then: refuse the past)."""
        s = self.mav.signing
        notice = None
        try:
            state = load(self.path)
        except SigningStateError as exc:
            now = self.now_ticks()
            s.timestamp = max(s.timestamp, now)
            s.stream_floor = max(s.stream_floor, now)
            state, notice = None, f"{exc}; starting afresh: frames stamped before now are refused"
        if state is not None:
            margin = RESTART_MARGIN_TICKS
            s.timestamp = max(s.timestamp, min(state.timestamp + margin, MAX_TICKS))
            s.stream_floor = max(s.stream_floor, state.floor)
            for stream, ts in state.streams.items():
                s.stream_timestamps[stream] = max(s.stream_timestamps.get(stream, 0), min(ts + margin, MAX_TICKS))
        self.save()  # a damaged file is replaced at once
        return notice

    def save(self) -> bool:
        """Save if anything changed since the last save; False if the disk refused (counted, not raised)."""
        s = self.mav.signing
        s.timestamp = max(s.timestamp, self.now_ticks())  # what we sign from now on is newer than the file
        state = SigningState.of(self.mav)
        if state == self._saved:
            return True
        try:
            save(self.path, state)
        except OSError:
            self.save_errors += 1
            return False
        self._saved = state
        return True
