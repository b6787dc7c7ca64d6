"""Replay of a recorded run: the model rebuilt from the GCS .tlog and events.jsonl; the replay app's keys."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

import pytest
from tui_helpers import screen_text, wait_for

from gcs.cli.main import main
from gcs.console.app import ReplayConsole
from gcs.records.playback import ReplayError, load_replay, read_tlog
from mussel_sim.vocabulary import MusselState

pytestmark = pytest.mark.tui


def _mission_end(run: Path) -> dict[str, object]:
    lines = [json.loads(line) for line in (run / "events.jsonl").read_text().splitlines()]
    return next(e for e in lines if e["event"] == "mission_end")


def test_replay_rebuilds_the_run(recorded_run: Path) -> None:
    replay = load_replay(recorded_run)
    end = _mission_end(recorded_run)
    assert replay.end_s == pytest.approx(float(end["t_s"]), abs=0.1)
    last = replay.frames[-1]
    # The movement cost recomputed from the Go To commands in the .tlog is the loop's own figure.
    assert last.cost_m == pytest.approx(float(end["cost_m"]), abs=1e-3)
    assert last.ended == "operator stop"
    assert list(last.mussel_ids) == list(range(1, 13))
    mid = replay.at(200.0)
    assert mid.t_s == 200.0 and mid.phase == "charging wait"
    assert int((mid.state == MusselState.DOCKED).sum()) == 4
    assert mid.hist_t_s.size == 201 and mid.hist_active[-1] == 8
    assert replay.at(-5).t_s == 0.0 and replay.at(1e9) is last


def test_replay_takes_a_tlog_too(recorded_run: Path) -> None:
    from_tlog = load_replay(recorded_run / "gcs.tlog")
    assert from_tlog.end_s == load_replay(recorded_run).end_s
    kinds = {msg.get_type() for _, msg in read_tlog(recorded_run / "gcs.tlog")}
    assert {"AMUSSEL_STATUS", "GLOBAL_POSITION_INT", "PRIMITIVE_STATUS", "COMMAND_INT"} <= kinds


def test_replay_errors_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(ReplayError):
        load_replay(tmp_path)
    assert main(["replay", str(tmp_path / "nothing")]) == 2
    assert "vil replay:" in capsys.readouterr().err


def test_replay_keys_play_pause_speed_seek(recorded_run: Path) -> None:
    async def scenario() -> None:
        app = ReplayConsole(load_replay(recorded_run), start_s=100.0, playing=False, speed=8.0)
        async with app.run_test(size=(150, 46)) as pilot:
            await pilot.pause(0.3)
            assert "REPLAY" in screen_text(app) and "01:40 / 40:00" in screen_text(app)
            await pilot.press("right")
            assert app.position_s == 110.0
            await pilot.press("left", "left")
            assert app.position_s == 90.0
            await pilot.press("plus")
            assert app.speed == 16.0
            await pilot.press("minus", "minus")
            assert app.speed == 4.0
            await pilot.press("space")
            assert app.playing
            await wait_for(pilot, lambda: app.position_s > 90.5)  # 4x: 0.4 s of mission per tick
            await pilot.press("space")
            stopped_at = app.position_s
            await pilot.pause(0.3)
            assert not app.playing and app.position_s == stopped_at < 100.0
            await pilot.press("end")
            await pilot.pause(0.2)
            assert app.position_s == app.replay.end_s and "mission ended: operator stop" in screen_text(app)
            await pilot.press("question_mark")
            await pilot.pause(0.2)
            assert "Play/pause" in screen_text(app) and "charged" in screen_text(app)
            await pilot.press("escape")
            await pilot.pause(0.1)
            assert "esc closes" not in screen_text(app)
            await pilot.press("home")
            assert app.position_s == 0.0

    asyncio.run(scenario())


def test_a_swarm_run_replays_with_every_apad_and_its_share(tmp_path: Path) -> None:
    from gcs.mission.headless import run_mission
    from gcs.scenario.reader import load_scenario

    run = tmp_path / "run"
    result = run_mission(load_scenario("pool12x2").with_overrides(duration_s=360.0), run)
    last = load_replay(run).frames[-1]
    assert [a.system_id for a in last.apads] == [1, 2]
    shares = {a.system_id: set(a.share) for a in last.apads}
    assert shares == {row["sysid"]: set(row["share_at_end"]) for row in result.apads}  # as the run shared it
    assert all(a.lat_deg is not None for a in last.apads)  # each aPad's own telemetry, from the .tlog


def test_runs_latest_replays_under_the_runs_own_name_and_ctrl_c_quits(recorded_run: Path, tmp_path: Path) -> None:
    """The title names the run's folder, not `latest`, however the run is given; ctrl+c quits as q."""
    latest = tmp_path / "latest"
    latest.symlink_to(recorded_run, target_is_directory=True)
    for given in (latest, latest / "gcs.tlog"):
        assert Path(load_replay(given).source).name == recorded_run.name

    async def scenario() -> None:
        app = ReplayConsole(load_replay(latest), playing=False)
        async with app.run_test(size=(150, 46)) as pilot:
            await pilot.pause(0.3)
            text = screen_text(app)
            assert f"REPLAY of {recorded_run.name}" in text and f"REPLAY  {recorded_run.name}" in text
            assert "latest" not in text
            await pilot.press("ctrl+c")
            await wait_for(pilot, lambda: not app.is_running)

    asyncio.run(scenario())


def test_replay_help_describes_replay_not_the_live_console(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["replay", "--help"])
    description = capsys.readouterr().out.split("\n\n")[1]
    assert description.startswith("`vil replay`: a recorded run")
    assert "vil gcs --" not in description and "start-up" not in description

