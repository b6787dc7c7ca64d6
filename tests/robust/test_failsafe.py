"""Link loss: the SITL aPad holds when the GCS heartbeat stops; latches carry on; the GCS picks up after."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from robust_helpers import latlon_e7, sitl_pair

from apad_sitl.params import ApadParams
from apad_sitl.vocabulary import Latch, Primitive
from gcs.link.faultproxy import LinkFaults
from gcs.mission.headless import run_mission
from gcs.mission.scenario import load_scenario
from gcs.mission.world import LinkOptions
from mavlink_dialect import MAV_CMD_APAD_DOCK, mavlink

pytestmark = pytest.mark.sitl


def test_failsafe_is_on_by_default() -> None:
    assert ApadParams().fs_gcs_enable == 1


def test_link_loss_while_docking_holds_and_the_latch_still_closes_and_charges() -> None:
    clock, vehicle, gcs = sitl_pair(ApadParams(fs_gcs_timeout_s=3.0))
    gcs.heartbeat()
    gcs.mussel(24, 0.5, 0.0)
    gcs.command_long(MAV_CMD_APAD_DOCK, 1, 24)
    assert vehicle.primitive.kind == Primitive.DOCK
    # The GCS goes silent (no more heartbeats).
    assert gcs.wait(lambda: vehicle.failsafe_active, 5.0)
    assert clock.time() == pytest.approx(1.0 + 3.0, abs=0.3)
    assert vehicle.primitive.kind == Primitive.HOLD
    assert gcs.wait(lambda: vehicle.primitive.slot_state(1).latch == Latch.LATCHED, 12.0)
    assert vehicle.primitive.slot_state(1).charging
    # The link comes back: the failsafe clears and the aPad takes commands again.
    gcs.heartbeat()
    clock.sleep(0.5)
    assert not vehicle.failsafe_active
    lat, lon = latlon_e7(20.0, 0.0)
    gcs.send(mavlink.MAVLink_command_int_message(1, 1, mavlink.MAV_FRAME_GLOBAL_INT, mavlink.MAV_CMD_DO_REPOSITION,
                                                 0, 0, -1, 1, 0, float("nan"), lat, lon, 0.0))
    assert gcs.acks(mavlink.MAV_CMD_DO_REPOSITION)[-1].result == mavlink.MAV_RESULT_ACCEPTED
    assert vehicle.primitive.slot_state(1).latch == Latch.LATCHED  # still on board while sailing
    vehicle.close()


def test_a_mission_rides_out_a_link_blackout(tmp_path: Path) -> None:
    """20 s of total loss during a Go To: the aPad holds, the GCS re-commands the Go To, nothing is lost."""
    s = load_scenario("pool12").with_overrides(strategy="greedy", duration_s=900.0)
    r = run_mission(s, tmp_path, options=LinkOptions(faults=LinkFaults(seed=1, outages_s=((92.0, 112.0),))))
    apad_events = [json.loads(x) for x in (tmp_path / "apad1.events.jsonl").read_text().splitlines()]
    [failsafe] = [e for e in apad_events if e["event"] == "failsafe"]
    assert failsafe["t_s"] == pytest.approx(92.0 + 5.0, abs=1.1)  # FS_GCS_TIMEOUT after the last heartbeat
    gcs_events = [json.loads(x) for x in (tmp_path / "events.jsonl").read_text().splitlines()]
    resumed = [e for e in gcs_events if e["event"] == "goto_resumed"]
    assert resumed and all(112.0 <= e["t_s"] < 130.0 for e in resumed)
    assert r.end_reason == "mission time" and r.cycles >= 1
    assert [w for w in r.whereabouts if w["where"] == "lost"] == []
