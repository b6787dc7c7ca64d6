"""Modes alone: `Modes` on a recording host, an `ApadState`, a registry and a virtual clock.

HOLD and GUIDED by DO_SET_MODE and by the legacy SET_MODE message, arming, and the GCS failsafe:
a GCS heard and then silent for FS_GCS_TIMEOUT makes a busy aPad hold where it is.
"""

from __future__ import annotations

from typing import Any

import pytest
from test_sitl_part_host import GCS, SYSID, RecordingHost, Registry

from apad_sitl import primitives as prim
from apad_sitl.modes import Modes
from apad_sitl.params import ApadParams
from apad_sitl.state import ApadState
from apad_sitl.vehicle import VehicleState
from apad_sitl.vocabulary import Primitive, Progress, RoverMode
from mavlink_dialect import mavlink
from missiontime import VirtualClock

CUSTOM = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
SET_MODE, ARM = mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_CMD_COMPONENT_ARM_DISARM
ACCEPTED, DENIED = mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_DENIED


class Bench:
    def __init__(self, params: ApadParams | None = None) -> None:
        self.host = RecordingHost()
        self.apad = ApadState(params or ApadParams())
        self.commands = Registry()
        self.modes = Modes(self.host, self.apad, self.commands)
        self.changes: list[tuple[str, Any]] = []
        self.apad.on_mode(lambda mode: self.changes.append(("mode", mode)))
        self.apad.on_armed(lambda armed: self.changes.append(("armed", armed)))


@pytest.fixture
def b() -> Bench:
    return Bench()


def test_guided_holds_where_the_hull_is_until_a_target_comes_and_hold_keeps_a_held_point(b: Bench) -> None:
    b.apad.state = VehicleState(x_m=3.0, y_m=-2.0)
    assert b.commands.run(SET_MODE, CUSTOM, RoverMode.GUIDED).result == ACCEPTED
    p = b.apad.primitive
    assert (b.apad.mode, p.kind, p.target_x_m, p.target_y_m) == (RoverMode.GUIDED, Primitive.HOLD, 3.0, -2.0)
    b.apad.set_primitive(prim.go_to(b.apad.primitive, 50.0, 0.0))
    assert b.commands.run(SET_MODE, CUSTOM, RoverMode.HOLD).result == ACCEPTED
    p = b.apad.primitive
    assert (b.apad.mode, p.kind, p.target_x_m, p.target_y_m) == (RoverMode.HOLD, Primitive.HOLD, 3.0, -2.0)
    assert b.changes == [("mode", RoverMode.GUIDED), ("mode", RoverMode.HOLD)]


def test_a_mode_that_is_none_of_the_apads_is_refused(b: Bench) -> None:
    assert b.commands.run(SET_MODE, CUSTOM, 3).invalid == "param2"
    assert b.commands.run(SET_MODE, 0, RoverMode.GUIDED).result == DENIED  # no custom mode flag
    assert b.commands.run(SET_MODE, 256, RoverMode.GUIDED).invalid == "param1"
    assert (b.apad.mode, b.changes) == (RoverMode.HOLD, [])


def test_the_legacy_set_mode_message_is_answered_with_an_ack(b: Bench) -> None:
    b.host.receive(mavlink.MAVLink_set_mode_message(SYSID, CUSTOM, RoverMode.GUIDED))
    b.host.receive(mavlink.MAVLink_set_mode_message(SYSID, CUSTOM, 99))
    b.host.receive(mavlink.MAVLink_set_mode_message(SYSID + 1, CUSTOM, RoverMode.HOLD))  # another aPad's
    acks = b.host.take()
    assert [(a.command, a.result, a.target_system, a.target_component) for a in acks] == [
        (mavlink.MAVLINK_MSG_ID_SET_MODE, ACCEPTED, *GCS), (mavlink.MAVLINK_MSG_ID_SET_MODE, DENIED, *GCS)]
    assert b.apad.mode == RoverMode.GUIDED
    assert b.host.dropped == {"invalid:SET_MODE:custom_mode": 1}


def test_arming_changes_the_state_once_and_only_to_0_or_1(b: Bench) -> None:
    assert b.commands.run(ARM, 0).result == ACCEPTED
    assert b.commands.run(ARM, 0).result == ACCEPTED
    assert b.commands.run(ARM, 0.5).invalid == "param1"
    assert (b.apad.armed, b.changes) == (False, [("armed", False)])


def test_a_silent_gcs_makes_a_busy_apad_hold_at_the_timeout() -> None:
    b = Bench(ApadParams(fs_gcs_timeout_s=5.0))
    clock = VirtualClock()
    b.modes.attach(clock.scheduler, 0, "apad1")
    b.host.receive(mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3))
    b.apad.state = VehicleState(x_m=7.0, y_m=1.0)
    b.apad.set_primitive(prim.go_to(b.apad.primitive, 50.0, 0.0))
    clock.advance_to(4_999_999)
    assert (b.modes.failsafe_active, b.modes.gcs_link_lost(), b.apad.primitive.kind) == (False, False, Primitive.GOTO)
    clock.advance_to(5_000_000)
    p = b.apad.primitive
    assert (b.modes.failsafe_active, b.host.now_us, b.modes.last_gcs_heartbeat_us) == (True, 5_000_000, 0)
    assert (b.apad.mode, p.kind, p.progress, p.target_x_m, p.target_y_m) == (
        RoverMode.HOLD, Primitive.HOLD, Progress.IN_PROGRESS, 7.0, 1.0)
    assert [m.text for m in b.host.take()] == ["GCS failsafe: heartbeat lost, holding"]
    assert b.host.events == [("failsafe", {"reason": "gcs heartbeat lost", "silent_s": 5.0})]


def test_an_aircrafts_heartbeat_is_not_a_gcs(b: Bench) -> None:
    b.host.now_us = 123
    b.host.receive(mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_SURFACE_BOAT, 3, 0, 0, 0, 3))
    assert b.modes.last_gcs_heartbeat_us is None
    b.host.receive(mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, 8, 0, 0, 0, 3))
    assert b.modes.last_gcs_heartbeat_us == 123
