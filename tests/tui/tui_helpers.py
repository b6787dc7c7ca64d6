"""Small helpers for driving the console apps headless."""

from __future__ import annotations

import time
from collections.abc import Callable

from textual import events
from textual.app import App
from textual.keys import key_to_character
from textual.pilot import Pilot


def screen_text(app: App[object]) -> str:
    """The screen as plain text, one line per row (what a person reads in the terminal)."""
    return "\n".join(strip.text.rstrip() for strip in app.screen._compositor.render_strips())


async def wait_for(pilot: Pilot[object], condition: Callable[[], bool], timeout_s: float = 15.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"condition not met within {timeout_s} s")
        await pilot.pause(0.05)


async def press(pilot: Pilot[object], *keys: str) -> None:
    """Pilot.press's key events, without its waits for an idle process. Pilot.press waits up to 1 s,
    twice a key, for the process to stop using CPU; a live console's world runs on in its worker thread,
    so the process never does and every key cost 2 s of idle wall time. Here each key is one Key event
    posted to the app, as the driver posts a terminal's, and the screen then handles all it has queued
    twice over: the app's binding first, then what it forwarded to the focused widget."""
    for key in keys:
        pilot.app.post_message(events.Key(key, key_to_character(key)))
        await pilot.pause(0)
        await pilot.pause(0)
