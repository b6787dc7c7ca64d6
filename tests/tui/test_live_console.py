"""The live console driven headless with Pilot: each key goes through the runner to the SITL aPad.

The world runs on a PacedClock (lockstep, 40x real time) in the console's worker thread, with the
SITL aPad over an in-memory pair of real MAVLink bytes; assertions read the SITL vehicle itself.
"""

from __future__ import annotations

import asyncio
import re
from pathlib import Path

import pytest
from tui_helpers import press, screen_text, wait_for

from apad_sitl.vocabulary import Primitive
from gcs.cli.main import main
from gcs.console.app import LiveConsole
from gcs.console.runner import ConsoleConfig, ConsoleRunner
from gcs.scenario.reader import load_scenario
from gcs.strategies import COLLECT
from mussel_sim.vocabulary import MusselState

pytestmark = [pytest.mark.tui, pytest.mark.sitl]

POOL12 = Path(__file__).resolve().parents[2] / "missions" / "pool12.toml"
SIZE = (150, 46)
HOLD_MODE = 4


def make_app(start_paused: bool = False, speed: float = 40.0) -> tuple[LiveConsole, ConsoleRunner]:
    runner = ConsoleRunner(ConsoleConfig(load_scenario(POOL12), sitl="memory", speed=speed, start_paused=start_paused))
    return LiveConsole(runner), runner


def events_of(runner: ConsoleRunner, kind: str) -> list[dict[str, object]]:
    assert runner.world is not None
    return [e.fields for e in list(runner.world.events.events) if e.kind == kind]


def test_map_and_table_appear_and_q_leaves_the_apad_holding() -> None:
    async def scenario() -> None:
        app, runner = make_app(start_paused=True)
        async with app.run_test(size=SIZE) as pilot:
            await wait_for(pilot, lambda: runner.snapshot is not None and runner.snapshot.apad_lat_deg is not None
                           and runner.snapshot.hist_t_s.size > 0)
            await wait_for(pilot, lambda: "loop paused" in screen_text(app))  # drawn by a later frame on a slow machine
            text = screen_text(app)
            assert "Map" in text and "◆" in text and "●" in text  # area, aPad, aMussels
            assert "battery %" in text and "uptime %" in text
            assert "loop paused" in text
            await press(pilot, "question_mark")
            await pilot.pause(0.1)
            assert "Override: hold" in screen_text(app) and "esc closes" in screen_text(app)
            assert "arrow keys" in " ".join(screen_text(app).split())  # what g, d and u act on
            await press(pilot, "escape")
            await pilot.pause(0.1)
            assert "esc closes" not in screen_text(app)
            await press(pilot, "q")
            await wait_for(pilot, runner.finished.is_set)
            await pilot.pause(0.2)
        assert not app.is_running
        vehicle = runner.world.vehicle
        assert vehicle is not None and vehicle.closed
        assert vehicle.mode == HOLD_MODE and vehicle.primitive.kind == Primitive.HOLD

    asyncio.run(scenario())


def test_pause_stops_the_loop_and_resume_restarts_it() -> None:
    async def scenario() -> None:
        app, runner = make_app(speed=200.0)  # what is waited for is mission time
        async with app.run_test(size=SIZE) as pilot:
            await wait_for(pilot, lambda: bool(runner.world and events_of(runner, "call_up")))
            await press(pilot, "p")
            await wait_for(pilot, lambda: runner.snapshot is not None and runner.snapshot.paused)
            assert runner.control.paused
            await pilot.pause(0.3)  # the loop reaches its next wait and stays there
            assert runner.snapshot is not None
            n_events, t0 = len(runner.world.events.events), runner.snapshot.t_s
            await wait_for(pilot, lambda: runner.snapshot is not None and runner.snapshot.t_s > t0 + 60)
            assert len(runner.world.events.events) == n_events  # the loop did nothing for 60 s of mission time
            assert runner.snapshot.t_s > t0 + 10  # while the world (aPad, fleet) ran on
            assert "PAUSED" in screen_text(app)
            await press(pilot, "p")
            await wait_for(pilot, lambda: len(runner.world.events.events) > n_events)
            assert not runner.control.paused
            runner.request_quit(now=True)
        runner.finished.wait(30)

    asyncio.run(scenario())


def test_override_sends_hold_to_the_sitl() -> None:
    async def scenario() -> None:
        app, runner = make_app()
        async with app.run_test(size=SIZE) as pilot:
            await wait_for(pilot, lambda: runner.world is not None and runner.world.vehicle is not None
                           and runner.world.vehicle.primitive.kind == Primitive.GOTO)
            await press(pilot, "o")
            vehicle = runner.world.vehicle
            await wait_for(pilot, lambda: vehicle.primitive.kind == Primitive.HOLD and vehicle.mode == HOLD_MODE)
            assert runner.control.paused and app.paused
            await wait_for(pilot, lambda: "override: aPad holding" in screen_text(app))
            # The SITL's own log saw the GCS's mode command.
            assert vehicle.mode == HOLD_MODE
            runner.request_quit(now=True)
        runner.finished.wait(30)

    asyncio.run(scenario())


def test_strategy_switch_takes_effect_at_the_next_planning_step() -> None:
    async def scenario() -> None:
        app, runner = make_app(start_paused=True)
        async with app.run_test(size=(160, 46)) as pilot:
            await wait_for(pilot, lambda: runner.snapshot is not None and runner.snapshot.apad_lat_deg is not None)
            first = load_scenario(POOL12).mission.collect_strategy
            wanted = COLLECT[(COLLECT.index(first) + 1) % len(COLLECT)]
            await press(pilot, "s")
            assert runner.control.strategy == wanted
            # At 160 columns the pending switch reads whole, and the events pane says it once.
            await wait_for(pilot, lambda: re.search(rf"next plan strategy {wanted} *│", screen_text(app)) is not None)
            await wait_for(pilot, lambda: f"operator strategy -> {wanted}" in screen_text(app))
            assert not events_of(runner, "plan_collection")  # nothing planned yet: the switch is pending
            await press(pilot, "p")
            await wait_for(pilot, lambda: bool(events_of(runner, "plan_collection")))
            assert events_of(runner, "strategy_switch") == [{"old": first, "new": wanted}]
            assert events_of(runner, "plan_collection")[0]["strategy"] == wanted
            await wait_for(pilot, lambda: runner.snapshot is not None and runner.snapshot.strategy == wanted)
            runner.request_quit(now=True)
        runner.finished.wait(30)

    asyncio.run(scenario())


def test_quit_now_mid_collection_holds_and_accounts_for_the_surfaced() -> None:
    """Q quits at once (bounded): the aPad holds, and every aMussel still at the surface is in the
    whereabouts the console logs as it quits (floating ones were sent down, surfacing ones left)."""
    async def scenario() -> None:
        app, runner = make_app()
        async with app.run_test(size=SIZE) as pilot:
            await wait_for(pilot, lambda: bool(runner.world and events_of(runner, "call_up")))
            await press(pilot, "Q")
            await wait_for(pilot, runner.finished.is_set, timeout_s=10)
        assert runner.error is None
        world = runner.world
        assert world is not None and world.vehicle is not None
        assert world.vehicle.mode == HOLD_MODE and world.vehicle.primitive.kind == Primitive.HOLD
        assert events_of(runner, "mission_end")[0]["reason"] == "operator stop"
        fleet = world.fleet.state
        up = {m for m, st in zip(fleet.ids.tolist(), fleet.state.tolist(), strict=True)
              if st in (int(MusselState.SURFACING), int(MusselState.FLOATING))}
        (where,) = events_of(runner, "whereabouts")
        assert up <= {int(m) for m in where["lost"]}

    asyncio.run(scenario())


def test_manual_go_to_dock_and_undock_of_the_selected_amussel() -> None:
    async def scenario() -> None:
        app, runner = make_app(start_paused=True)
        async with app.run_test(size=SIZE) as pilot:
            await wait_for(pilot, lambda: runner.snapshot is not None and runner.snapshot.hist_t_s.size > 1)
            await wait_for(pilot, lambda: app.fleet.row_count == 12)
            app.fleet.focus()
            await press(pilot, "down", "down")  # aMussel 3
            await wait_for(pilot, lambda: app.fleet.selected_mussel() == 3)
            await press(pilot, "g")
            vehicle = runner.world.vehicle
            await wait_for(pilot, lambda: vehicle.primitive.kind == Primitive.GOTO)
            home = runner.world.homes[3]  # the go-to target is where aMussel 3 was last heard
            lat, lon = vehicle.frame.to_geodetic(vehicle.primitive.target_x_m, vehicle.primitive.target_y_m)
            assert abs(float(lat) - home.lat) < 2e-5 and abs(float(lon) - home.lon) < 2e-5
            await wait_for(pilot, lambda: vehicle.primitive.progress.name == "DONE", timeout_s=30)
            await press(pilot, "d")
            await wait_for(pilot, lambda: any(s.mussel_id == 3 and s.latch.name == "LATCHED"
                                              for s in vehicle.primitive.slots), timeout_s=30)
            await wait_for(pilot, lambda: runner.snapshot is not None and runner.snapshot.slots[0].mussel_id == 3)
            assert "docked" in screen_text(app)
            await press(pilot, "u")
            await wait_for(pilot, lambda: all(s.mussel_id == 0 for s in vehicle.primitive.slots), timeout_s=30)
            await press(pilot, "Q")
            await wait_for(pilot, runner.finished.is_set, timeout_s=30)
        assert runner.error is None and runner.world.vehicle.mode == HOLD_MODE

    asyncio.run(scenario())


def test_messages_the_link_refuses_are_counted_on_screen() -> None:
    """Someone on the aPad's network speaking as this GCS: refused, and the operator sees it."""
    from mavlink_dialect import Codec, mavlink

    async def scenario() -> None:
        app, runner = make_app(start_paused=True)
        async with app.run_test(size=SIZE) as pilot:
            await wait_for(pilot, lambda: runner.snapshot is not None and runner.snapshot.apad_lat_deg is not None)
            assert "refused" not in screen_text(app)
            assert runner.world is not None and runner.world.vehicle is not None
            spoof = Codec(250, 190).encode(mavlink.MAVLink_heartbeat_message(
                mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3))
            for _ in range(3):
                runner.world.vehicle.transport.send(spoof)  # arrives at the GCS from the aPad's side
            await wait_for(pilot, lambda: runner.snapshot is not None and runner.snapshot.dropped >= 3)
            await pilot.pause(0.3)
            text = screen_text(app)
            assert "refused" in text and "spoofed_source:HEARTBEAT" in text
            await press(pilot, "q")
            await wait_for(pilot, runner.finished.is_set)

    asyncio.run(scenario())


def test_plain_vil_gcs_suggests_sitl_for_a_first_look(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["gcs"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("vil gcs: ") and "--sitl for a first look" in err
