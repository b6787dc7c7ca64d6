"""The GCS paces the aPad's telemetry by activity (issue 20, idle time costs little): slow while the
loop holds in place (its holding phases, above a called-up aMussel until it floats, while a strategy
takes nobody), fast while it moves, asked with SET_MESSAGE_INTERVAL. Checked on the real bytes the
GCS recorded (its .tlog): the requests and ACKs, and the GLOBAL_POSITION_INT the aPad then sent.
"""

from __future__ import annotations

import json
from itertools import pairwise
from pathlib import Path
from typing import Any

import pytest
from testkit import read_jsonl, scenario_variant

from gcs.link.faultproxy import LinkFaults
from gcs.link.telemetry import GCS_SYSTEM_ID
from gcs.loop.control import LoopLog, Phase
from gcs.loop.telemetry_pace import (
    HOLDING_PHASES,
    HOLDING_TELEMETRY_HZ,
    MOVING_TELEMETRY_HZ,
    PLANNING_PHASES,
    TelemetryPace,
)
from gcs.mission.headless import run_mission
from gcs.mission.world import LOCKSTEP_EPOCH_US, LinkOptions, headless_world
from gcs.records.run_folder import RunFolder
from gcs.scenario.reader import load_scenario
from mavlink_dialect import Codec, mavlink, tlog

pytestmark = pytest.mark.sitl

GPI = mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT
US = 1_000_000


def decoded(path: Path) -> list[tuple[float, Any]]:
    """(mission seconds, message) for every frame of a lockstep run's .tlog, parsed afresh."""
    codec = Codec(200, 1)
    return [((stamp - LOCKSTEP_EPOCH_US) / US, msg)
            for stamp, frame in tlog.frames(path) for msg in codec.decode(frame)]


@pytest.fixture(scope="module")
def pool12_run(tmp_path_factory: pytest.TempPathFactory) -> RunFolder:
    out = tmp_path_factory.mktemp("pace") / "run"
    run_mission(load_scenario("pool12").with_overrides(duration_s=900.0), out)
    return RunFolder(out)


def position_requests(run: RunFolder) -> list[tuple[float, int, float]]:
    """(mission seconds, message id, interval us) of each SET_MESSAGE_INTERVAL the GCS sent for the position."""
    return [(t, int(m.param1), m.param2) for t, m in decoded(run.gcs_tlog)
            if m.get_type() == "COMMAND_LONG" and m.get_srcSystem() == GCS_SYSTEM_ID
            and m.command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL and int(m.param1) == GPI]


def test_the_gcs_asks_slow_while_holding_and_fast_while_moving(pool12_run: RunFolder) -> None:
    msgs = decoded(pool12_run.gcs_tlog)
    asked = position_requests(pool12_run)
    acks = [m for _, m in msgs if m.get_type() == "COMMAND_ACK" and m.command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL]
    assert acks and all(a.result == mavlink.MAV_RESULT_ACCEPTED for a in acks)
    holding_us, moving_us = US / HOLDING_TELEMETRY_HZ[GPI], US / MOVING_TELEMETRY_HZ[GPI]
    intervals = [interval for _, _, interval in asked]
    # The world's start asks moving rates; then each change of activity flips it, never twice alike.
    assert intervals[0] == moving_us and holding_us in intervals and intervals.count(moving_us) >= 2
    assert all(a != b for a, b in pairwise(intervals[1:]))

    # Slow asked only in a holding phase of the loop, fast only in one that acts, never while planning:
    # pool12's aMussels are always on, so the wait above one (its 20-s rise) is not worth pacing.
    events = [json.loads(line) for line in pool12_run.events.read_text().splitlines()]
    phases = [(e["t_s"], e["phase"]) for e in events if e.get("event") == "phase"]
    assert any(p in HOLDING_PHASES for _, p in phases) and any(p not in HOLDING_PHASES for _, p in phases)
    for t_asked, _, interval in asked[1:]:
        phase = [p for t, p in phases if t <= round(t_asked, 3)][-1]
        assert phase not in PLANNING_PHASES, (t_asked, phase)
        assert interval == (holding_us if phase in HOLDING_PHASES else moving_us), (t_asked, phase)


def test_above_a_sleeper_called_up_the_apad_reports_slowly_until_it_moves_again(tmp_path: Path) -> None:
    """A sleeper rises only at its wake (up to two minutes at theta 30): the aPad holds above it with slow
    telemetry, and asks for fast telemetry again before it closes in and docks."""
    path = scenario_variant("pool12", tmp_path / "pool12-sleep.toml", {"[fleet]": '[fleet]\nprofile = "hourly_wake"'})
    out = tmp_path / "run"
    run_mission(load_scenario(path).with_overrides(duration_s=480.0), out)
    run = RunFolder(out)
    events = [json.loads(line) for line in run.events.read_text().splitlines()]
    phases = [(e["t_s"], e["phase"]) for e in events if e.get("event") == "phase"]
    call_ups = [e["t_s"] for e in events if e.get("event") == "call_up"]
    docks = [e["t_s"] for e in events if e.get("event") == "docked"]
    asked = position_requests(run)
    holding_us, moving_us = US / HOLDING_TELEMETRY_HZ[GPI], US / MOVING_TELEMETRY_HZ[GPI]
    above = 0
    for (t_asked, _, interval), (t_next, _, next_interval) in pairwise(asked[1:]):
        phase = [p for t, p in phases if t <= round(t_asked, 3)][-1]
        if interval != holding_us or phase != Phase.COLLECT:
            continue
        # Slow in collect: waiting for the aMussel called up last (none docked since), fast again before
        # the next dock.
        called = max(t for t in call_ups if t <= round(t_asked, 3))
        assert not [t for t in docks if called < t <= t_asked], (t_asked, called)  # (one docks as the next is called)
        assert next_interval == moving_us and not [t for t in docks if t_asked <= t < t_next], (t_asked, t_next)
        above += 1
    assert above >= 2 and len(docks) >= 2


def test_the_apad_reports_its_position_at_the_rate_asked(pool12_run: RunFolder) -> None:
    msgs = decoded(pool12_run.gcs_tlog)
    asked = [(t, m.param2) for t, m in msgs if m.get_type() == "COMMAND_LONG"
             and m.command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL and int(m.param1) == GPI]
    positions = [t for t, m in msgs if m.get_type() == "GLOBAL_POSITION_INT" and m.get_srcSystem() == 1]
    holding_s, moving_s = 1 / HOLDING_TELEMETRY_HZ[GPI], 1 / MOVING_TELEMETRY_HZ[GPI]
    spans = [(t0, t1, interval / US) for (t0, interval), (t1, _) in pairwise([*asked, (positions[-1], 0.0)])]
    seen = {holding_s: 0, moving_s: 0}
    for t0, t1, period_s in spans:
        # After the first report at the new rate (within one period), reports keep that period.
        inside = [t for t in positions if t0 + period_s < t < t1]
        gaps = [round(b - a, 6) for a, b in pairwise(inside)]
        for gap in gaps:
            assert gap == pytest.approx(period_s, abs=1e-6), (t0, period_s, gaps)
        seen[period_s] += sum(1 for gap in gaps if gap == pytest.approx(period_s, abs=1e-6))
    assert seen[holding_s] >= 10 and seen[moving_s] >= 100


def test_a_strategy_that_takes_nobody_leaves_the_apad_reporting_slowly(tmp_path: Path) -> None:
    """The loop asks the strategy again every REPLAN_S, holding meanwhile: planning does not speed the
    telemetry up, and the aPad reports its position at the holding rate from the first wait on."""
    (tmp_path / "patient.py").write_text("def nobody(inp, weights):\n    return {a: [] for a in inp.apads}\n")
    out = tmp_path / "run"
    run_mission(load_scenario("pool12").with_overrides(strategy=f"{tmp_path / 'patient.py'}:nobody",
                                                      duration_s=900.0), out)  # not too late to call up
    run = RunFolder(out)
    events = [json.loads(line) for line in run.events.read_text().splitlines()]
    assert sum(e.get("phase") == Phase.PLAN_COLLECT for e in events) >= 20  # asked again and again
    asked = position_requests(run)
    holding_us, moving_us = US / HOLDING_TELEMETRY_HZ[GPI], US / MOVING_TELEMETRY_HZ[GPI]
    end_s = next(e["t_s"] for e in events if e.get("phase") == Phase.ENDED)
    # Slow once, fast again only when the loop ends (it leaves the aPad with the rates it found).
    assert [(interval, t == end_s) for t, _, interval in asked[1:]] == [(holding_us, False), (moving_us, True)]
    positions = [t for t, m in decoded(run.gcs_tlog)
                 if m.get_type() == "GLOBAL_POSITION_INT" and m.get_srcSystem() == 1 and t > asked[1][0] + 5.0]
    assert len(positions) >= 50
    assert all(round(b - a, 6) == 1 / HOLDING_TELEMETRY_HZ[GPI] for a, b in pairwise(positions))


def test_a_rate_request_lost_on_the_link_is_asked_again_at_the_next_change(tmp_path: Path) -> None:
    """Issue 39: of the two requests for moving telemetry the position's was lost (both sends in an
    outage) and the primitive's taken. The aPad then sailed a collection reporting its position every
    5 s while the loop believed 2 Hz: at 40 % loss the GCS and the fleet heard it 20 s late, and a
    docking failed. The lost one must not count as made: the next change asks for it again."""
    out = tmp_path / "run"
    faults = LinkFaults(outages_s=((20.0, 22.4),))  # the position's two sends (20 s, 21 s), not the primitive's
    world = headless_world(load_scenario("pool12"), out, LinkOptions(faults=faults))
    try:
        world.api.wait_apad(timeout_s=10.0)
        pace = TelemetryPace(world.api, world.scenario.apad.system_id, LoopLog(world.events, world.clock))
        world.clock.sleep(10.0 - world.clock.time())
        pace.hold()
        assert pace.holding
        world.clock.sleep(20.0 - world.clock.time())
        pace.move()
        assert pace.holding  # the position is not known to be fast again
        world.clock.sleep(25.0 - world.clock.time())
        pace.move()  # the loop's next command that moves the aPad
        assert not pace.holding
        world.clock.sleep(40.0 - world.clock.time())
    finally:
        world.close()
    failed = [e for e in read_jsonl(RunFolder(out).events) if e["event"] == "telemetry_rate_failed"]
    assert [e["message"] for e in failed] == ["GLOBAL_POSITION_INT"]
    heard = [t for t, m in decoded(RunFolder(out).gcs_tlog) if m.get_type() == "GLOBAL_POSITION_INT"]
    assert len([t for t in heard if 30.0 <= t < 40.0]) >= 18  # 2 Hz, not one every 5 s
