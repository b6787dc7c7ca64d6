"""The mission's end during a redeployment: a release in progress completes and is reported where it
is, the aMussels still on board stay on their slots, and no new leg starts after the end. A real
headless run (SITL aPad, fleet, GCS over MAVLink bytes)."""

from __future__ import annotations

from pathlib import Path

import pytest
from testkit import read_jsonl, scenario_variant

from gcs.mission.headless import run_mission
from gcs.scenario.reader import load_scenario

pytestmark = pytest.mark.sitl

END_S = 370.0


def test_a_release_in_progress_at_the_end_completes_and_nothing_is_reported_lost(tmp_path: Path) -> None:
    """pool12 with a 30 s undock, ended at 382 s: the first redeployment ([3, 11, 6]) is undocking
    aMussel 11 then (its latch opens after the end; the window is 370..398 s). Before the fix the
    fleet model, which takes no step past the end, never applied the latch that opened after it:
    11 stayed "docked on aPad 1 slot 1, unknown to the GCS" on an open slot (`vil run` exit 3), and
    the loop sent the aPad to 6's position after the end, counting that leg in the cost."""
    variant = scenario_variant("pool12", tmp_path / "end.toml", {
        'duration = "40m"': f'duration = "{END_S:.0f}s"', "undock_time_s = 5": "undock_time_s = 30"})
    out = tmp_path / "run"
    r = run_mission(load_scenario(variant), out)
    events = read_jsonl(out / "events.jsonl")

    route = [e for e in events if e["event"] == "plan_redeployment"][-1]["route"]
    released = [e for e in events if e["event"] == "released"]
    late = [e["mussel"] for e in released if e["t_s"] > END_S]
    assert late, "precondition: a release completed after the end (the timeline moved: pick another end)"
    (mussel,) = late
    on_board = route[route.index(mussel) + 1:]
    assert on_board, "precondition: the route had more aMussels to put back"

    where = {w["id"]: w for w in r.whereabouts}
    assert [w for w in r.whereabouts if w["where"] == "lost"] == []
    assert where[mussel]["where"] == "seabed" and where[mussel]["detail"].startswith("sinking, ")
    assert all(where[m]["where"] == "slot" for m in on_board)
    assert r.end_reason == "mission time"

    # No leg after the end: the aPad was not sent on towards the next aMussel's position.
    apad_events = read_jsonl(out / "apad1.events.jsonl")
    assert not [e for e in apad_events if e["event"] == "command" and e["name"] == "MAV_CMD_DO_REPOSITION"
                and e["t_s"] > END_S]
    assert r.cost_m == pytest.approx(r.travelled_m, abs=0.1)
