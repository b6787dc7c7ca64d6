"""The live console on an acoustic scenario, driven headless with Pilot: the fleet table shows how old
what the GCS knows of each aMussel is, and marks it stale once reports have been lost.

The world (SITL aPad over real MAVLink bytes, the aMussels' modems and the GCS's driver over the
emulator's serial bytes) runs on the console's PacedClock; assertions read the screen.
"""

from __future__ import annotations

import asyncio
import re
from dataclasses import replace

import pytest
from tui_helpers import screen_text, wait_for

from gcs.console.app import LiveConsole
from gcs.console.runner import ConsoleConfig, ConsoleRunner
from gcs.mission.scenario import load_scenario
from gcs.view.snapshot import STALE_S, age_text
from mussel_sim.vocabulary import MusselState

pytestmark = [pytest.mark.tui, pytest.mark.sitl]

SIZE = (150, 46)


def test_age_text_says_how_old_and_marks_stale() -> None:
    assert [age_text(a) for a in (float("nan"), 0.4, 17.2, STALE_S + 1, 900.0, 40_000.0)] == [
        "-", "now", "17s", "61s!", "15m!", "11h!"]


def test_the_fleet_table_shows_the_age_of_what_was_heard_and_marks_stale_amussels() -> None:
    pool = load_scenario("missions/pool12-acoustic.toml")
    # A noisy sea (54 dB over the default noise): about a third of the reports are lost, so some
    # aMussel goes unheard for more than a minute.
    scenario = replace(pool, acoustic=replace(pool.acoustic, noise_psd_db=104.0))
    runner = ConsoleRunner(ConsoleConfig(scenario, sitl="memory", speed=1000.0))
    app = LiveConsole(runner)

    def stale_row() -> int | None:
        snap = runner.snapshot
        if snap is None or snap.heard_age_s.size == 0:
            return None
        for k, age in enumerate(snap.heard_age_s.tolist()):
            if age > STALE_S + 5 and snap.state[k] == MusselState.ACTIVE:
                return int(snap.mussel_ids[k])
        return None

    async def scenario_run() -> None:
        async with app.run_test(size=SIZE) as pilot:
            await wait_for(pilot, lambda: runner.snapshot is not None
                           and bool((runner.snapshot.heard_age_s > 2.0).any()), timeout_s=60.0)
            assert "heard" in screen_text(app)
            await wait_for(pilot, lambda: stale_row() is not None, timeout_s=120.0)
            mussel = stale_row()
            assert mussel is not None
            await wait_for(pilot, lambda: re.search(rf"^\s*{mussel}\s+active\s.*\d+[smh]!", table_text(app), re.M)
                           is not None)
            await pilot.press("q")
            await wait_for(pilot, runner.finished.is_set)

    asyncio.run(scenario_run())


def table_text(app: LiveConsole) -> str:
    """The fleet table's rows as text (the right-hand panel of each screen line)."""
    return "\n".join(line.split("││")[-1] for line in screen_text(app).splitlines() if "││" in line)
