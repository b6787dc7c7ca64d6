"""Telemetry alone: `Streams` on a recording host, an `ApadState`, a registry and a virtual clock.

Streams at their rates in mission time, SET_MESSAGE_INTERVAL (clamped to 50 Hz), requested
messages after the ACK, and the on-change announcement a primitive change sets off.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import replace

import pytest
from test_sitl_part_host import SYSID, RecordingHost, Registry

from apad_sitl import primitives as prim
from apad_sitl.dege7 import DegE7
from apad_sitl.host import Reply
from apad_sitl.params import ApadParams
from apad_sitl.primitives import SlotState
from apad_sitl.state import ApadState
from apad_sitl.streams import Streams
from apad_sitl.vocabulary import Latch, RoverMode
from mavlink_dialect import mavlink
from missiontime import VirtualClock
from mussel_sim.geo import LocalFrame

HOME = (43.94, 15.44)
ACCEPTED, DENIED = mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_DENIED
ATTITUDE = mavlink.MAVLINK_MSG_ID_ATTITUDE


class Telemetry:
    def __init__(self, rates_hz: dict[int, float] | None = None) -> None:
        self.host = RecordingHost()
        self.apad = ApadState(ApadParams())
        self.commands = Registry()
        self.frame = LocalFrame(*HOME)
        self.target_e7 = DegE7(self.frame)
        self.streams = Streams(self.host, self.apad, self.commands, self.frame, SYSID, rates_hz, self.target_e7)
        self.clock = VirtualClock()
        self.attached = False

    def run(self, seconds: float) -> Counter[str]:
        """Attach (once) and run the clock for `seconds`; what was sent, counted by type."""
        if not self.attached:
            self.streams.attach(self.clock.scheduler, self.clock.now_us, "apad1")
            self.attached = True
        self.clock.advance_to(self.clock.now_us + round(seconds * 1e6) - 1)
        return Counter(self.host.types())

    def command(self, command: int, *params: float) -> Reply:
        """A command handled now (the vehicle's latest task, physics at 10 Hz, dated it about now)."""
        self.host.now_us = self.clock.now_us
        return self.commands.run(command, *params)


@pytest.fixture
def tm() -> Telemetry:
    return Telemetry()


def test_streams_go_out_at_their_default_rates_and_date_the_host(tm: Telemetry) -> None:
    sent = tm.run(2.0)
    assert sent == {"HEARTBEAT": 2, "GLOBAL_POSITION_INT": 8, "SYS_STATUS": 2, "BATTERY_STATUS": 2,
                    "PRIMITIVE_STATUS": 4, "DOCK_SLOT_STATUS": 8}
    assert tm.host.now_us == 1_750_000  # the last stream task to fire (GLOBAL_POSITION_INT at 4 Hz)


def test_a_rate_given_at_construction_and_one_set_by_command(tm: Telemetry) -> None:
    quiet = Telemetry({mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 0.0, ATTITUDE: 2.0})
    assert quiet.run(1.0)["GLOBAL_POSITION_INT"] == 0
    interval = mavlink.MAV_CMD_SET_MESSAGE_INTERVAL
    tm.run(0.5)
    assert tm.command(interval, ATTITUDE, 100_000).result == ACCEPTED
    assert tm.run(1.0)["ATTITUDE"] == 10
    assert tm.command(interval, ATTITUDE, 1).result == ACCEPTED  # 1 µs: clamped to 20 ms
    assert tm.run(1.0)["ATTITUDE"] == 50
    assert tm.command(interval, ATTITUDE, -1).result == ACCEPTED  # stop it
    assert tm.run(1.0)["ATTITUDE"] == 0
    assert tm.command(interval, ATTITUDE, float("inf")).invalid == "param2"
    assert tm.command(interval, mavlink.MAVLINK_MSG_ID_MISSION_COUNT, 0).result == DENIED  # not ours to send


def test_a_requested_message_is_sent_once_by_the_reply(tm: Telemetry) -> None:
    request = mavlink.MAV_CMD_REQUEST_MESSAGE
    assert tm.commands.run(request, mavlink.MAVLINK_MSG_ID_DOCK_SLOT_STATUS, 3).result == ACCEPTED
    assert [(m.get_type(), m.slot) for m in tm.host.take()] == [("DOCK_SLOT_STATUS", 3)]
    tm.commands.run(request, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
    (version,) = tm.host.take()
    assert (version.get_type(), version.uid) == ("AUTOPILOT_VERSION", SYSID)
    tm.commands.run(mavlink.MAV_CMD_GET_HOME_POSITION)
    (home,) = tm.host.take()
    assert (home.latitude, home.longitude) == (round(HOME[0] * 1e7), round(HOME[1] * 1e7))
    assert tm.commands.run(request, float("nan")).invalid == "param1"
    assert tm.commands.run(request, mavlink.MAVLINK_MSG_ID_DOCK_SLOT_STATUS, 5).invalid == "param2"
    assert tm.host.take() == []


def test_the_heartbeat_says_the_mode_and_arming_of_the_state(tm: Telemetry) -> None:
    tm.apad.set_mode(RoverMode.GUIDED)
    tm.apad.set_armed(False)
    tm.streams.send_heartbeat()
    (hb,) = tm.host.take()
    assert (hb.custom_mode, hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED) == (RoverMode.GUIDED, 0)
    tm.host.closed = True
    tm.streams.send_heartbeat()
    assert tm.host.take() == []


def test_a_primitive_change_announces_what_changed_and_echoes_a_remembered_target(tm: Telemetry) -> None:
    tm.apad.on_primitive(tm.streams.primitive_changed)
    target = (round(43.9401 * 1e7), round(15.4402 * 1e7))
    x, y = (float(v) for v in tm.frame.to_local(43.9401, 15.4402))
    tm.target_e7.remember(x, y, *target)  # what navigation does with a Go To's target
    tm.apad.set_primitive(prim.go_to(tm.apad.primitive, x, y))
    sent = tm.host.take()
    assert [m.get_type() for m in sent] == ["DOCK_SLOT_STATUS"] * 4 + ["PRIMITIVE_STATUS"]  # nothing sent before
    assert (sent[-1].target_lat, sent[-1].target_lon) == target

    slots = list(tm.apad.primitive.slots)
    slots[1] = SlotState(24, Latch.CLOSING, False, 10.0)
    tm.apad.set_primitive(replace(tm.apad.primitive, slots=tuple(slots)))
    assert [(m.get_type(), m.slot, m.mussel_id) for m in tm.host.take()] == [("DOCK_SLOT_STATUS", 2, 24)]
    tm.apad.set_primitive(replace(tm.apad.primitive, speed_mps=0.2))  # nothing a status shows
    assert tm.host.take() == []
    tm.host.closed = True
    tm.apad.set_primitive(prim.hold(tm.apad.primitive, 0.0, 0.0))
    assert tm.host.take() == []
