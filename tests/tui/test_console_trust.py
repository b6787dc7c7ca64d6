"""The console an operator can trust: the link on screen, actions and refusals logged in words, a
clean handover between the operator and the loop, a quick quit, a clock that stops at the end.

The world runs on a PacedClock (40x) with the SITL aPad over an in-memory pair of real MAVLink
bytes; "killed" is the embedded aPad falling silent (`ConsoleConfig.fail_apads`: its tasks stop,
its transport closes).
"""

from __future__ import annotations

import asyncio
import time
from pathlib import Path

import numpy as np
import pytest
from testkit import read_jsonl, scenario_variant
from tui_helpers import press, screen_text, wait_for

from gcs.console.app import LiveConsole
from gcs.console.confirm import ConfirmQuit
from gcs.console.link_health import LOST_S, Level
from gcs.console.runner import ConsoleConfig, ConsoleRunner
from gcs.scenario.reader import load_scenario
from mussel_sim.vocabulary import MusselState

pytestmark = [pytest.mark.tui, pytest.mark.sitl]

POOL12 = Path(__file__).resolve().parents[2] / "missions" / "pool12.toml"
SIZE = (150, 46)


def make_app(out: Path | None = None, scenario: Path = POOL12, speed: float = 40.0,
             **config: object) -> tuple[LiveConsole, ConsoleRunner]:
    runner = ConsoleRunner(ConsoleConfig(load_scenario(scenario), sitl="memory", speed=speed, out_dir=out,
                                         **config))  # type: ignore[arg-type]
    return LiveConsole(runner), runner


def kinds(runner: ConsoleRunner, kind: str) -> list[dict[str, object]]:
    assert runner.world is not None
    return [e.fields | {"t_s": e.t_s} for e in list(runner.world.events.events) if e.kind == kind]


def test_a_silent_apad_shows_link_lost_within_3_s_of_mission_time() -> None:
    fail_at_s = 80.0  # 2 s of wall time at 40x: the test sees the link fine first

    async def scenario() -> None:
        app, runner = make_app(start_paused=True, fail_apads=((1, fail_at_s),))
        async with app.run_test(size=SIZE) as pilot:
            await wait_for(pilot, lambda: bool(runner.link_status) and runner.link_status[0].level == Level.OK)
            await wait_for(pilot, lambda: "aPad 1 ●" in screen_text(app))  # the link bar drawn, the link fine
            assert runner.world is not None and not kinds(runner, "link_lost")
            await wait_for(pilot, lambda: "LINK LOST: aPad 1 silent" in screen_text(app))
            (lost,) = kinds(runner, "link_lost")
            assert lost["link"] == "aPad 1" and float(lost["t_s"]) <= fail_at_s + LOST_S + 0.2  # mission time
            assert all(h.level == Level.OK for h in runner.link_status[1:])  # the fleet stream goes on
            assert "LIVE" not in screen_text(app)
            await press(pilot, "Q")  # quits although the aPad cannot acknowledge the hold
            await wait_for(pilot, lambda: not app.is_running)
        assert runner.finished.is_set() and not app.world_thread.is_alive()

    asyncio.run(scenario())


def test_override_then_a_refused_dock_hands_back_to_the_loop_and_q_still_quits(tmp_path: Path) -> None:
    async def scenario() -> None:
        app, runner = make_app(tmp_path)
        async with app.run_test(size=SIZE) as pilot:
            await wait_for(pilot, lambda: bool(runner.world and kinds(runner, "call_up")))
            called = int(kinds(runner, "call_up")[0]["mussel"])
            await press(pilot, "o")
            await wait_for(pilot, lambda: bool(kinds(runner, "operator")) and runner.control.paused)
            await wait_for(pilot, lambda: app.fleet.row_count == 12)
            far = 12 if called != 12 else 1
            app.fleet.select_mussel(far)
            await wait_for(pilot, lambda: app.fleet.selected_mussel() == far)
            await press(pilot, "d")
            await wait_for(pilot, lambda: bool(kinds(runner, "refused")))
            (refused,) = kinds(runner, "refused")
            assert refused["action"] == "dock" and refused["mussel"] == far
            assert refused["why"] == f"aMussel {far} out of docking reach"
            await wait_for(pilot, lambda: "out of docking reach" in screen_text(app))
            # The loop takes the aPad back where it was (a Go To the override replaced is sent again:
            # `goto_resent`) and docks the aMussel it called up, instead of waiting out its bounds.
            await press(pilot, "p")
            await wait_for(pilot, lambda: any(d["mussel"] == called for d in kinds(runner, "docked")), timeout_s=20)
            assert not kinds(runner, "goto_timeout") and not kinds(runner, "gave_up")
            await press(pilot, "Q")
            await wait_for(pilot, lambda: not app.is_running)
        assert runner.finished.is_set() and not app.world_thread.is_alive()
        logged = read_jsonl(tmp_path / "events.jsonl")
        actions = [(e["event"], e.get("action")) for e in logged if e["event"] in ("operator", "refused")]
        assert actions[:4] == [("operator", "pause"), ("operator", "override"), ("refused", "dock"),
                               ("operator", "resume")]
        assert ("operator", "quit") in actions and logged[-1]["event"] == "whereabouts"

    asyncio.run(scenario())


def test_q_and_ctrl_c_ask_while_amussels_float_and_quit_within_the_bound(tmp_path: Path) -> None:
    async def scenario() -> None:
        app, runner = make_app(tmp_path, speed=8.0)  # slow enough to pause before the aMussel is docked
        async with app.run_test(size=SIZE) as pilot:
            await wait_for(pilot, lambda: bool(runner.world and kinds(runner, "call_up")))
            await press(pilot, "o")  # the loop paused: the aMussel it called up floats until it resumes
            await wait_for(pilot, lambda: runner.control.paused and runner.snapshot is not None and bool(
                np.isin(runner.snapshot.state, [MusselState.SURFACING, MusselState.FLOATING]).any()))
            await press(pilot, "q")
            await wait_for(pilot, lambda: isinstance(app.screen, ConfirmQuit))
            assert "aMussels are at the surface" in screen_text(app)
            await press(pilot, "n")
            await wait_for(pilot, lambda: not isinstance(app.screen, ConfirmQuit))
            assert app.is_running and not runner.finished.is_set()
            await press(pilot, "ctrl+c")  # an operator's reflex: the same question as q, not Textual's toast
            await wait_for(pilot, lambda: isinstance(app.screen, ConfirmQuit))
            await press(pilot, "ctrl+c")  # pressed again while it asks: it still waits for the answer
            await pilot.pause(0.2)
            assert isinstance(app.screen, ConfirmQuit) and len(app.screen_stack) == 2 and app.is_running
            pressed = time.monotonic()
            await press(pilot, "y")
            await wait_for(pilot, lambda: not app.is_running)
            print(f"quit took {time.monotonic() - pressed:.3f} s of wall time")  # measured, not asserted
        assert runner.finished.is_set() and not app.world_thread.is_alive() and runner.error is None
        logged = [e.get("action") for e in read_jsonl(tmp_path / "events.jsonl") if e["event"] == "operator"]
        # The override is logged once its command is acknowledged, on the world thread: it may come after the
        # cancelled quit (a fresh clone's suite). The quit asked and cancelled, then the quit, last.
        assert "override" in logged and logged[-1] == "quit" and "quit_cancelled" in logged[:-1], logged

    asyncio.run(scenario())


def test_ctrl_q_quits_like_q_and_the_clock_stops_at_the_missions_end(tmp_path: Path) -> None:
    short = scenario_variant("pool12", tmp_path / "short.toml", {'duration = "40m"': 'duration = "30s"'})

    async def scenario() -> None:
        app, runner = make_app(scenario=short)
        async with app.run_test(size=SIZE) as pilot:
            await wait_for(pilot, lambda: runner.snapshot is not None and runner.snapshot.ended is not None)
            end_s = runner.snapshot.t_s
            await wait_for(pilot, lambda: "mission ended" in screen_text(app) and "its time is up" in screen_text(app))
            await pilot.pause(0.5)  # 20 s of mission time: the world runs on, the mission clock does not
            assert runner.snapshot.t_s == end_s and 30.0 <= end_s < 32.0
            await press(pilot, "ctrl+q")
            await wait_for(pilot, lambda: not app.is_running)
        assert runner.finished.is_set() and not app.world_thread.is_alive()

    asyncio.run(scenario())
