"""A scheduler poller that feeds what a transport received to a handler of bytes (the fleet's `feed`)."""

from __future__ import annotations

from collections.abc import Callable

from mavlink_dialect.transport import Transport


class TransportPoller:
    def __init__(self, transport: Transport, feed: Callable[[bytes], object]) -> None:
        self.transport = transport
        self.feed = feed

    def poll(self) -> bool:
        handled = False
        for data in self.transport.receive():
            handled = True
            self.feed(data)
        return handled

    def fileno(self) -> int | None:
        return self.transport.fileno()
