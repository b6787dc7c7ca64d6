"""The live console on a swarm (pool12x2: two embedded SITL aPads, one loop each), driven with Pilot.

Both aPads are shown with their shares of the fleet; `a` picks aPad 2, and the go-to and override
keys then command aPad 2 and leave aPad 1 as it was. Assertions read the SITL vehicles themselves.
"""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest
from tui_helpers import screen_text, wait_for

from apad_sitl.endpoint import SitlVehicle
from apad_sitl.vocabulary import Primitive
from gcs.console.app import LiveConsole
from gcs.console.fleetview import FleetTable
from gcs.console.runner import ConsoleConfig, ConsoleRunner
from gcs.console.widgets import APAD_COLOURS
from gcs.scenario.reader import load_scenario

pytestmark = [pytest.mark.tui, pytest.mark.sitl]

POOL12X2 = Path(__file__).resolve().parents[2] / "missions" / "pool12x2.toml"
SIZE = (150, 46)
HOLD_MODE = 4
# Slow enough that the world thread idles between its steps: Pilot waits for an idle process
# after each key (up to 2 s a key when the world keeps a core busy).
SPEED = 4.0


def loop_events(runner: ConsoleRunner, apad: int) -> list[str]:
    assert runner.world is not None
    return [e.kind for e in list(runner.world.events.events) if e.fields.get("apad") == apad]


def test_both_apads_shown_with_their_shares_and_the_keys_command_the_selected_one() -> None:
    async def scenario() -> None:
        runner = ConsoleRunner(ConsoleConfig(load_scenario(POOL12X2), sitl="memory", speed=SPEED))
        app = LiveConsole(runner)
        async with app.run_test(size=SIZE) as pilot:
            # Both loops run: each logs its own phases, named by its aPad.
            await wait_for(pilot, lambda: runner.world is not None
                           and all("phase" in loop_events(runner, a) for a in (1, 2)))
            await wait_for(pilot, lambda: runner.snapshot is not None and all(
                a.share and a.lat_deg is not None and a.trace_lat_deg.size for a in runner.snapshot.apads))
            snap = runner.snapshot
            assert [a.system_id for a in snap.apads] == [1, 2] and snap.selected == 1
            share1, share2 = (set(a.share) for a in snap.apads)
            assert not share1 & share2 and share1 | share2 == set(range(1, 13))  # FleetShares.owner, every aMussel
            assert sorted(snap.owner.tolist()) == sorted([1] * len(share1) + [2] * len(share2))
            # The other aPad's line, drawn from a snapshot with the shares: the screen follows the snapshot
            # at its own refresh, later on a loaded machine (a frame of the first seconds has no shares yet).
            other = ("◆ aPad 2 ", f"share {len(share2)}")
            await wait_for(pilot, lambda: all(line in screen_text(app) for line in other))
            await wait_for(pilot, lambda: "a Next aPad" in screen_text(app))  # the footer, once its keys are laid out
            text = screen_text(app)
            assert "◆ aPad 1  selected of 2" in text and f"share {len(share2)}" in text
            assert "share     " + " ".join(map(str, sorted(share1))) in text
            table = app.query_one(FleetTable)
            assert table.render_line(0).text.split()[-1] == "aPad"  # the fleet table says whose each aMussel is
            first = int(snap.mussel_ids[0])
            assert table.render_line(1).text.split()[-1] == str(1 if first in share1 else 2)
            assert APAD_COLOURS[1].lower() in app.export_screenshot().lower()  # aPad 2's own colour
            assert "a Next aPad" in text  # in the footer, and in the help
            app.action_help()
            await wait_for(pilot, lambda: "esc closes" in screen_text(app))
            assert "Next aPad" in screen_text(app) and "each aMussel shows the number" in screen_text(app)
            app.pop_screen()

            await pilot.press("a")
            assert runner.selected == 2
            await wait_for(pilot, lambda: "◆ aPad 2  selected of 2" in screen_text(app))
            app.paused = True  # what p does: both loops pause, from here only the operator moves the aPads
            await wait_for(pilot, lambda: runner.snapshot is not None and runner.snapshot.paused)
            await pilot.pause(0.5)  # each loop reaches its next wait and stays there
            world = runner.world
            assert world is not None
            one, two = world.vehicles[1], world.vehicles[2]

            def seen(v: SitlVehicle) -> tuple[object, ...]:
                return v.primitive.kind, v.primitive.target_x_m, v.primitive.target_y_m, v.mode

            before = seen(one)
            target = min(share1)  # aPad 1's aMussel: aPad 2's own loop would never go there
            await wait_for(pilot, lambda: app.fleet.row_count == 12)
            app.fleet.move_cursor(row=target - 1)
            assert app.fleet.selected_mussel() == target
            await pilot.press("g")
            home = world.homes[target]

            def going_to_target() -> bool:
                p = two.primitive
                if p.kind != Primitive.GOTO:
                    return False
                lat, lon = two.frame.to_geodetic(p.target_x_m, p.target_y_m)
                return abs(float(lat) - home.lat) < 2e-5 and abs(float(lon) - home.lon) < 2e-5

            await wait_for(pilot, going_to_target)
            await wait_for(pilot, lambda: f"manual: aPad 2 going to aMussel {target}" in screen_text(app))
            assert seen(one) == before
            await pilot.press("o")
            await wait_for(pilot, lambda: two.primitive.kind == Primitive.HOLD and two.mode == HOLD_MODE)
            assert seen(one) == before
            await wait_for(pilot, lambda: "override: aPad 2 holding" in screen_text(app))
            app.action_quit_console(now=True)  # what Q does
            await wait_for(pilot, runner.finished.is_set, timeout_s=30)
        assert runner.error is None
        ends = [e.fields for e in world.events.events if e.kind == "mission_end"]
        assert sorted(int(str(f["apad"])) for f in ends) == [1, 2]
        assert all(v.mode == HOLD_MODE for v in world.vehicles.values())

    asyncio.run(scenario())
