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
from gcs.scenario.reader import load_scenario
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
    runner = ConsoleRunner(ConsoleConfig(scenario, sitl="memory", speed=200.0))
    app = LiveConsole(runner)
    stale_on_screen = re.compile(r"^\s*(\d+)\s+active\s.*?\s\d+[smh]!", re.M)  # the panel's border follows

    def stale_row_drawn() -> bool:
        """A row drawn stale ("74s!") whose age the snapshot agrees is past STALE_S: read in one go, so a
        report that arrives meanwhile cannot take the row away between the two looks."""
        snap = runner.snapshot
        if snap is None or snap.heard_age_s.size == 0:
            return False
        for m in stale_on_screen.finditer(table_text(app)):
            k = [int(i) for i in snap.mussel_ids].index(int(m[1]))
            if snap.heard_age_s[k] > STALE_S and int(snap.state[k]) == MusselState.ACTIVE:
                return True
        return False

    async def scenario_run() -> None:
        async with app.run_test(size=SIZE) as pilot:
            await wait_for(pilot, lambda: runner.snapshot is not None
                           and bool((runner.snapshot.heard_age_s > 2.0).any()), timeout_s=60.0)
            assert "heard" in screen_text(app)
            await wait_for(pilot, stale_row_drawn, timeout_s=120.0)
            await pilot.press("Q")
            await wait_for(pilot, runner.finished.is_set, timeout_s=30.0)

    asyncio.run(scenario_run())


def table_text(app: LiveConsole) -> str:
    """The fleet table's rows as text (the right-hand panel of each screen line)."""
    return "\n".join(line.split("││")[-1] for line in screen_text(app).splitlines() if "││" in line)


def test_a_two_apad_acoustic_console_shares_the_fleet_as_it_is_heard() -> None:
    # pool12x2 with the sea between them: at the start the GCS has heard nobody, so nobody has an aPad;
    # each aMussel joins a share when it is first heard in its slot, and the table says whose it is.
    pool_x2 = load_scenario("missions/pool12x2.toml")
    runner = ConsoleRunner(ConsoleConfig(replace(pool_x2, acoustic=replace(pool_x2.acoustic, enabled=True)),
                                         sitl="memory", speed=10.0))  # a frame (18.6 s) in about 2 s
    app = LiveConsole(runner)
    joined_first: list[int] = []

    def every_amussel_shared() -> bool:
        snap = runner.snapshot
        if snap is None or len(snap.apads) != 2:
            return False
        if not joined_first:
            joined_first.append(sum(len(a.share) for a in snap.apads))
        return sorted(m for a in snap.apads for m in a.share) == list(range(1, 13))

    async def scenario_run() -> None:
        async with app.run_test(size=SIZE) as pilot:
            await wait_for(pilot, every_amussel_shared, timeout_s=120.0)
            snap = runner.snapshot
            assert snap is not None
            shares = {a.system_id: set(a.share) for a in snap.apads}
            assert len(shares[1]) == len(shares[2]) == 6  # the nearest aPad with room, an even share
            owner = dict(zip(snap.mussel_ids.tolist(), snap.owner.tolist(), strict=True))
            assert all(owner[m] == apad for apad, ids in shares.items() for m in ids)
            await wait_for(pilot, lambda: "heard" in screen_text(app) and "share 6" in screen_text(app))
            await pilot.press("Q")
            await wait_for(pilot, runner.finished.is_set, timeout_s=30.0)

    asyncio.run(scenario_run())
    assert joined_first and joined_first[0] < 12  # shared as heard, not all at the start
    assert runner.world is not None
    joined = [e for e in runner.world.events.events if e.kind == "joined"]
    assert sorted(m for e in joined for ids in e.fields["shares"].values() for m in ids) == list(range(1, 13))
