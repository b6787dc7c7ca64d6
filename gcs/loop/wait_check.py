"""Each wait's declaration held to what lockstep sees (`VIL_CHECK_WAITS=1`; the suite runs missions so).

A wait declares when time alone could turn it true (`look_by`, `gcs.loop.wake_times`); everything else that
turns it true is news (`FleetKnowledge.news`). Lockstep looks at every poll whatever the declaration says, so it
can tell a wrong one: a wait found true with nothing heard since its last look, before the instant that look
declared, was turned by something it did not declare. A platform that wakes only on news and at `look_by`
would have slept through it. That is a bug in the declaration: `WaitDeclarationError`.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Hashable

from missiontime import Clock

ENABLED = os.environ.get("VIL_CHECK_WAITS") == "1"  # read once: a debugging aid for tests, not a setting


class WaitDeclarationError(AssertionError):
    """A wait turned true by something its declaration does not name."""


class WaitCheck:
    """One wait's looks, each compared with the one before."""

    def __init__(self, news: Callable[[], Hashable], clock: Clock, look_by: Callable[[], float | None] | None,
                 what: str) -> None:
        self.news = news
        self.clock = clock
        self.look_by = look_by
        self.what = what
        self.last: tuple[Hashable, float | None] | None = None  # after a look that said no

    def looked(self, done: Callable[[], bool]) -> bool:
        """`done()`, checked against the last look's declaration."""
        before = self.news()
        answer = done()
        now_s = self.clock.time()
        if answer and self.last is not None:
            heard_then, by_s = self.last
            if before == heard_then and (by_s is None or now_s < by_s):
                declared = "only news" if by_s is None else f"time alone at {by_s:.3f} s"
                raise WaitDeclarationError(f"{self.what}: true at {now_s:.3f} s with nothing heard since the last "
                                           f"look, which declared {declared}")
        self.last = None if answer else (self.news(), None if self.look_by is None else self.look_by())
        return answer
