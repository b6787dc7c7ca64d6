"""The console's layout from 80x24 to 250x70, read off the rendered screen: the fleet table shows
rows, every key of the footer is visible whole, the map gives way to the tables when narrow and
the plots give way when short. The replay console (a recorded pool12 run) and the live console
(the embedded SITL, paused) each resized in one session.
"""

from __future__ import annotations

import asyncio
import re
from pathlib import Path

import pytest
from textual.binding import Binding
from textual.pilot import Pilot
from tui_helpers import screen_text, wait_for

from gcs.console.app import ConsoleApp, LiveConsole, ReplayConsole
from gcs.console.runner import ConsoleConfig, ConsoleRunner
from gcs.records.playback import load_replay
from gcs.scenario.reader import load_scenario

pytestmark = pytest.mark.tui

POOL12 = Path(__file__).resolve().parents[2] / "missions" / "pool12.toml"
FLEET_ROW = re.compile(r"│\s+\d+\s+(active|surfacing|floating|docked|sinking|depleted)\s+[\d.-]+\s+[\d.]+\s")
Size = tuple[tuple[int, int], bool, bool, int]  # (size, map shown, plots shown, fleet rows at least)
SIZES: list[Size] = [((80, 24), False, False, 4), ((100, 30), True, False, 8), ((250, 70), True, True, 12)]


def footer_keys(app: ConsoleApp) -> list[str]:
    """What the footer must show for each key it offers: "key description"."""
    shown = [b for b in app.screen.active_bindings.values() if b.binding.show and b.enabled]
    return [f"{app.get_key_display(b.binding)} {b.binding.description}" for b in shown
            if isinstance(b.binding, Binding)]


def fleet_rows(text: str) -> int:
    return sum(1 for line in text.split("\n") if FLEET_ROW.search(line))


async def check_sizes(app: ConsoleApp, pilot: Pilot[None], sizes: list[Size]) -> None:
    for (width, height), map_shown, plots_shown, rows in sizes:
        await pilot.resize_terminal(width, height)
        keys = footer_keys(app)

        def laid_out() -> bool:
            text = screen_text(app)
            return fleet_rows(text) >= rows and all(k in text for k in keys)  # noqa: B023

        await wait_for(pilot, laid_out)
        text = screen_text(app)
        lines = text.split("\n")
        assert len(lines) == height and max(len(line) for line in lines) <= width
        footer = "\n".join(lines[-2:])  # one line, or two when the keys need them
        assert all(k in footer for k in keys), f"{width}x{height}: footer cut: {footer!r}"
        assert ("╭─ Map" in text) == map_shown, f"{width}x{height}: map shown should be {map_shown}"
        assert ("aMussel battery" in text) == plots_shown, f"{width}x{height}: plots shown should be {plots_shown}"
        assert "id  state" in text and "events" in text


def test_replay_console_from_80x24_to_250x70(recorded_run: Path) -> None:
    async def scenario() -> None:
        app = ReplayConsole(load_replay(recorded_run), start_s=200.0, playing=False)
        async with app.run_test(size=(150, 46)) as pilot:
            await check_sizes(app, pilot, SIZES)

    asyncio.run(scenario())


def test_live_console_at_80x24_and_100x30_keeps_every_key() -> None:
    async def scenario() -> None:
        runner = ConsoleRunner(ConsoleConfig(load_scenario(POOL12), sitl="memory", speed=40.0, start_paused=True))
        app = LiveConsole(runner)
        async with app.run_test(size=(150, 46)) as pilot:
            await wait_for(pilot, lambda: runner.snapshot is not None and runner.snapshot.mussel_ids.size == 12)
            await check_sizes(app, pilot, SIZES[:2])
            assert "p Pause" in screen_text(app) and "d Dock" in screen_text(app)

    asyncio.run(scenario())


def test_at_120_columns_the_status_shows_a_go_tos_mode_whole(recorded_run: Path) -> None:
    """Issue 23: at 120 columns the status line cut "mode GUI..." after a long Go To primitive."""
    replay = load_replay(recorded_run)
    t_s = next(f.t_s for f in replay.frames if "GO" in f.primitive.upper() and f.mode == "GUIDED")

    async def scenario() -> None:
        app = ReplayConsole(replay, start_s=t_s, playing=False)
        async with app.run_test(size=(120, 40)) as pilot:
            await wait_for(pilot, lambda: "mode GUIDED" in screen_text(app))

    asyncio.run(scenario())
