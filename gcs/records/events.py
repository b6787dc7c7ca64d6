"""The mission's event log: JSON lines with mission time, kept in memory for the console too."""

from __future__ import annotations

import json
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO


@dataclass
class Event:
    t_s: float  # mission time
    kind: str
    fields: dict[str, Any] = field(default_factory=dict)

    def line(self) -> str:
        return json.dumps({"t_s": round(self.t_s, 3), "event": self.kind, **self.fields}, sort_keys=False)


class EventLog:
    """Append-only; every event is flushed so a killed process loses nothing already logged.
    `muted`: events are kept in memory but not written (a resumed lockstep mission replaying what
    the file holds)."""

    def __init__(self, path: Path | None = None, keep: int = 10_000, append: bool = False) -> None:
        """`append` continues an existing log (a resumed mission); otherwise a new run starts it afresh."""
        self.events: list[Event] = []
        self.keep = keep
        self._file: TextIO | None = path.open("a" if append else "w", encoding="utf-8") if path else None
        # The file's length: a checkpoint keeps it, so a resumed run cuts what the crashed one logged later.
        self.bytes = path.stat().st_size if path is not None and append else 0
        self.muted = False
        self.counts: Counter[str] = Counter()  # every event emitted, by kind (the list keeps the last `keep`)

    def emit(self, t_s: float, kind: str, **fields: Any) -> Event:
        event = Event(t_s, kind, fields)
        self.events.append(event)
        self.counts[kind] += 1
        if len(self.events) > self.keep:
            del self.events[: len(self.events) - self.keep]
        if self._file is not None and not self.muted:
            line = event.line() + "\n"
            self._file.write(line)
            self._file.flush()
            self.bytes += len(line.encode("utf-8"))
        return event

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None
