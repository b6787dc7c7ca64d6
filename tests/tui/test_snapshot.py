"""Snapshot of the main screen: a recorded pool12 run (seed 1, lockstep) replayed to 200 s, 150x46.

The golden text is what a person reads; the SVG export must also be identical between two
renders and carry the marker colours. Regenerate with VIL_UPDATE_SNAPSHOTS=1 after a deliberate
change, and look at the diff.
"""

from __future__ import annotations

import asyncio
import os
from pathlib import Path

import pytest
from tui_helpers import screen_text, wait_for

from gcs.console.app import ReplayConsole
from gcs.console.widgets import APAD, GREEN, PURPLE, RED
from gcs.records.playback import load_replay

pytestmark = pytest.mark.tui

GOLDEN = Path(__file__).parent / "snapshots" / "replay_main_150x46.txt"


def render(run: Path) -> tuple[str, str]:
    async def scenario() -> tuple[str, str]:
        app = ReplayConsole(load_replay(run), start_s=200.0, playing=False)
        async with app.run_test(size=(150, 46)) as pilot:
            await wait_for(pilot, lambda: "q Quit" in screen_text(app))  # the footer lays out its keys last
            await pilot.pause(0.3)
            return screen_text(app), app.export_screenshot()

    return asyncio.run(scenario())


def test_main_screen_snapshot(recorded_run: Path) -> None:
    text, svg = render(recorded_run)
    if os.environ.get("VIL_UPDATE_SNAPSHOTS"):
        GOLDEN.parent.mkdir(exist_ok=True)
        GOLDEN.write_text(text + "\n")
    assert text + "\n" == GOLDEN.read_text()
    for colour in (GREEN, RED, PURPLE, APAD):  # charged, pool candidates, docked, the aPad
        assert colour.lower() in svg.lower()
    text2, svg2 = render(recorded_run)
    assert (text2, svg2) == (text, svg)
