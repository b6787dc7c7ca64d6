"""The SITL aPad over real MAVLink bytes: a bare Codec(250, 190) plays the GCS.

In-memory pair + VirtualClock for lockstep (deterministic, fast), and one short real-time run
over real UDP sockets with the WallClock.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from collections.abc import Callable, Iterator
from itertools import pairwise
from pathlib import Path
from typing import Any

import pytest
from testkit import free_udp_port

from apad_sitl.endpoint import SitlVehicle
from apad_sitl.params import PARAMS, ApadParams
from apad_sitl.primitives import Refusal
from apad_sitl.vocabulary import Latch, Primitive, Progress
from mavlink_dialect import (
    MAV_CMD_APAD_DOCK,
    MAV_CMD_APAD_UNDOCK,
    Codec,
    Transport,
    mavlink,
    memory_pair,
    open_transport,
)
from missiontime import Scheduler, VirtualClock, WallClock
from mussel_sim.geo import LocalFrame, distance_m
from mussel_sim.vocabulary import MusselState

pytestmark = pytest.mark.sitl

HOME = (43.94, 15.44)
FRAME = LocalFrame(*HOME)
SYSID = 1
ACCEPTED = mavlink.MAV_RESULT_ACCEPTED
DENIED = mavlink.MAV_RESULT_DENIED
Msg = Any  # a decoded pymavlink message


def latlon_e7(x_m: float, y_m: float) -> tuple[int, int]:
    lat, lon = FRAME.to_geodetic(x_m, y_m)
    return round(float(lat) * 1e7), round(float(lon) * 1e7)


class Gcs:
    """A bare MAVLink GCS: its own Codec, an inbox of decoded messages, and helpers to wait."""

    def __init__(self, transport: Transport, clock: VirtualClock | WallClock) -> None:
        self.codec = Codec(250, 190)
        self.transport = transport
        self.clock = clock
        self.inbox: list[Msg] = []

    # Poller protocol
    def poll(self) -> bool:
        data = self.transport.receive()
        for chunk in data:
            self.inbox.extend(self.codec.decode(chunk))
        return bool(data)

    def fileno(self) -> int | None:
        return self.transport.fileno()

    def send(self, msg: Msg) -> None:
        self.transport.send(self.codec.encode(msg))

    def received(self, msg_type: str, since: int = 0) -> list[Msg]:
        return [m for m in self.inbox[since:] if m.get_type() == msg_type]

    def wait_for(self, msg_type: str, pred: Callable[[Msg], bool] = lambda m: True,
                 timeout_s: float = 5.0, since: int | None = None) -> Msg:
        start = len(self.inbox) if since is None else since
        deadline = self.clock.time() + timeout_s
        while True:
            for m in self.inbox[start:]:
                if m.get_type() == msg_type and pred(m):
                    return m
            start = len(self.inbox)
            if self.clock.time() >= deadline:
                raise AssertionError(f"no {msg_type} within {timeout_s} s")
            self.clock.sleep(0.05)

    def ack(self, command: int, since: int) -> Msg:
        return self.wait_for("COMMAND_ACK", lambda m: m.command == command, timeout_s=1.0, since=since)

    def command_long(self, command: int, *params: float, target: int = SYSID) -> Msg:
        p = [*params, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0][:7]
        mark = len(self.inbox)
        self.send(mavlink.MAVLink_command_long_message(target, 1, command, 0, *p))
        return self.ack(command, mark)

    def reposition(self, x_m: float, y_m: float, speed: float = -1.0, radius: float = 0.0,
                   frame: int = mavlink.MAV_FRAME_GLOBAL_INT) -> Msg:
        lat_e7, lon_e7 = latlon_e7(x_m, y_m)
        mark = len(self.inbox)
        self.send(mavlink.MAVLink_command_int_message(
            SYSID, 1, frame, mavlink.MAV_CMD_DO_REPOSITION, 0, 0,
            speed, mavlink.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, radius, math.nan, lat_e7, lon_e7, 0.0))
        return self.ack(mavlink.MAV_CMD_DO_REPOSITION, mark)

    def mussel(self, mussel_id: int, x_m: float, y_m: float, state: MusselState = MusselState.FLOATING) -> None:
        lat_e7, lon_e7 = latlon_e7(x_m, y_m)
        self.send(mavlink.MAVLink_amussel_status_message(
            self.clock.now_us, mussel_id, lat_e7, lon_e7, 0.0, 0.8, 4080, int(state), 1))
        self.clock.sleep(0.0)

    def wait_primitive_done(self, timeout_s: float = 300.0) -> Msg:
        return self.wait_for("PRIMITIVE_STATUS", lambda m: m.progress == Progress.DONE, timeout_s)

    def slot(self, slot: int, since: int = 0) -> Msg:
        return self.received_slot(slot, since)[-1]

    def received_slot(self, slot: int, since: int = 0) -> list[Msg]:
        return [m for m in self.received("DOCK_SLOT_STATUS", since) if m.slot == slot]


class World:
    def __init__(self, tmp_path: Path, params: ApadParams | None = None, current: tuple[float, float] = (0.0, 0.0)):
        params = params or ApadParams()
        vehicle_end, gcs_end = memory_pair()
        self.clock = VirtualClock(Scheduler())
        self.vehicle = SitlVehicle(vehicle_end, params, *HOME, system_id=SYSID, current_mps=current,
                                   log_dir=tmp_path)
        self.vehicle.attach(self.clock.scheduler)
        self.gcs = Gcs(gcs_end, self.clock)
        self.clock.scheduler.add_poller(self.gcs)


@pytest.fixture
def world(tmp_path: Path) -> Iterator[World]:
    w = World(tmp_path)
    w.clock.sleep(1.0)
    yield w
    w.vehicle.close()


def position(gcs: Gcs) -> tuple[float, float]:
    gpi = gcs.received("GLOBAL_POSITION_INT")[-1]
    return gpi.lat / 1e7, gpi.lon / 1e7


# ---------------------------------------------------------------------------- looks like a boat


def test_it_looks_like_an_ardurover_boat(world: World) -> None:
    gcs = world.gcs
    world.clock.sleep(10.0)
    hb = gcs.received("HEARTBEAT")[-1]
    assert (hb.type, hb.autopilot) == (mavlink.MAV_TYPE_SURFACE_BOAT, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA)
    assert hb.base_mode & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    assert hb.custom_mode == 4  # HOLD
    assert hb.get_srcSystem() == SYSID and hb.get_srcComponent() == mavlink.MAV_COMP_ID_AUTOPILOT1
    ss = gcs.received("SYS_STATUS")[-1]
    prearm = mavlink.MAV_SYS_STATUS_PREARM_CHECK
    assert ss.onboard_control_sensors_present & ss.onboard_control_sensors_enabled & \
        ss.onboard_control_sensors_health & prearm
    assert ss.voltage_battery == pytest.approx(16000, abs=5)
    bs = gcs.received("BATTERY_STATUS")[-1]
    assert bs.voltages[0] == ss.voltage_battery and bs.battery_remaining == 100
    assert position(gcs) == pytest.approx(HOME, abs=1e-7)
    # Default rates over 11 s of mission time (tasks fire at t = 0 too).
    assert len(gcs.received("HEARTBEAT")) == 12
    assert len(gcs.received("GLOBAL_POSITION_INT")) == 4 * 11 + 1
    assert len(gcs.received("PRIMITIVE_STATUS")) == 2 * 11 + 1
    assert len(gcs.received_slot(3)) == 12
    assert gcs.codec.stats.bad_data == 0


# ---------------------------------------------------------------------------- go to


@pytest.mark.parametrize("frame", [mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                                   mavlink.MAV_FRAME_GLOBAL_INT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT])
def test_reposition_goes_to_the_point_and_stops_within_the_victory_radius(world: World, frame: int) -> None:
    gcs = world.gcs
    mark = len(gcs.inbox)
    ack = gcs.reposition(30.0, -20.0, radius=2.0, frame=frame)
    assert (ack.result, ack.target_system, ack.target_component) == (ACCEPTED, 250, 190)
    # The new status precedes the ACK: a script that returns on the ACK never reads a stale DONE.
    first = gcs.received("PRIMITIVE_STATUS", mark)[0]
    assert gcs.inbox.index(first) < gcs.inbox.index(ack)
    assert (first.primitive, first.progress) == (Primitive.GOTO, Progress.IN_PROGRESS)
    assert (first.target_lat, first.target_lon) == latlon_e7(30.0, -20.0)  # echoed exactly
    done = gcs.wait_primitive_done()
    assert (done.target_lat, done.target_lon) == latlon_e7(30.0, -20.0)
    world.clock.sleep(30.0)
    lat, lon = position(gcs)
    target = FRAME.to_geodetic(30.0, -20.0)
    assert float(distance_m(lat, lon, *target)) <= 2.0
    assert gcs.received("HEARTBEAT")[-1].custom_mode == 15  # GUIDED
    assert gcs.received("PRIMITIVE_STATUS")[-1].distance_travelled == pytest.approx(math.hypot(30, 20), rel=0.02)


def test_reposition_over_command_long_in_degrees(world: World) -> None:
    lat, lon = FRAME.to_geodetic(10.0, 10.0)
    ack = world.gcs.command_long(mavlink.MAV_CMD_DO_REPOSITION, -1, 1, 0, math.nan, float(lat), float(lon), 0)
    assert ack.result == ACCEPTED
    world.gcs.wait_primitive_done()
    world.clock.sleep(10.0)
    # float32 degrees carry ~0.5 m of rounding here: COMMAND_INT is the precise way.
    assert float(distance_m(*position(world.gcs), lat, lon)) <= 1.0


@pytest.mark.parametrize(("frame", "x", "y"), [
    (mavlink.MAV_FRAME_LOCAL_NED, 10, 10),  # not a global frame
    (mavlink.MAV_FRAME_GLOBAL_INT, 0, 0),  # unset
    (mavlink.MAV_FRAME_GLOBAL_INT, 459400000, 154400000),  # 200 km north of home: a typo
])
def test_bad_reposition_is_denied(world: World, frame: int, x: int, y: int) -> None:
    mark = len(world.gcs.inbox)
    world.gcs.send(mavlink.MAVLink_command_int_message(
        SYSID, 1, frame, mavlink.MAV_CMD_DO_REPOSITION, 0, 0, -1, 0, 0, 0, x, y, 0.0))
    assert world.gcs.ack(mavlink.MAV_CMD_DO_REPOSITION, mark).result == DENIED
    assert world.vehicle.primitive.kind == Primitive.IDLE


def test_unknown_command_is_unsupported_and_other_systems_commands_are_not_ours(world: World) -> None:
    assert world.gcs.command_long(mavlink.MAV_CMD_NAV_TAKEOFF).result == mavlink.MAV_RESULT_UNSUPPORTED
    assert world.gcs.command_long(31000).result == mavlink.MAV_RESULT_UNSUPPORTED
    with pytest.raises(AssertionError, match="no COMMAND_ACK"):
        world.gcs.command_long(mavlink.MAV_CMD_NAV_TAKEOFF, target=2)


def test_modes_arm_and_change_speed(world: World) -> None:
    gcs = world.gcs
    flag = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert gcs.command_long(mavlink.MAV_CMD_DO_SET_MODE, flag, 15).result == ACCEPTED
    assert gcs.wait_for("HEARTBEAT").custom_mode == 15
    assert world.vehicle.primitive.kind == Primitive.HOLD  # GUIDED holds until a target comes
    assert gcs.command_long(mavlink.MAV_CMD_DO_SET_MODE, flag, 0).result == DENIED  # MANUAL: not on an aPad
    assert gcs.command_long(mavlink.MAV_CMD_DO_SET_MODE, 0, 4).result == DENIED
    gcs.reposition(100.0, 0.0)
    world.clock.sleep(10.0)
    assert gcs.command_long(mavlink.MAV_CMD_DO_CHANGE_SPEED, 1, 0.2, -1).result == ACCEPTED
    world.clock.sleep(10.0)
    assert world.vehicle.state.ground_speed_mps == pytest.approx(0.2, abs=0.01)
    assert gcs.command_long(mavlink.MAV_CMD_DO_CHANGE_SPEED, 1, -5).result == DENIED
    assert gcs.command_long(mavlink.MAV_CMD_DO_SET_MODE, flag, 4).result == ACCEPTED  # HOLD stops the Go To
    assert gcs.wait_for("HEARTBEAT").custom_mode == 4
    assert world.vehicle.primitive.kind == Primitive.HOLD
    world.clock.sleep(20.0)
    assert world.vehicle.state.ground_speed_mps < 0.01
    assert gcs.command_long(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0).result == ACCEPTED
    assert not gcs.wait_for("HEARTBEAT").base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    assert gcs.command_long(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == ACCEPTED
    assert gcs.wait_for("HEARTBEAT").base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED


# ---------------------------------------------------------------------------- parameters


def param_set(gcs: Gcs, name: str, value: float) -> Msg:
    mark = len(gcs.inbox)
    gcs.send(mavlink.MAVLink_param_set_message(SYSID, 1, name.encode(), value, mavlink.MAV_PARAM_TYPE_REAL32))
    return gcs.wait_for("PARAM_VALUE", lambda m: m.param_id == name, timeout_s=1.0, since=mark)


def goto_duration_s(world: World, x_m: float) -> float:
    start = world.clock.time()
    world.gcs.reposition(x_m, 0.0)
    world.gcs.wait_primitive_done()
    return world.clock.time() - start


def test_param_set_speed_max_changes_how_long_a_go_to_takes(world: World) -> None:
    fast = goto_duration_s(world, 40.0)
    pv = param_set(world.gcs, "SPEED_MAX", 0.25)
    assert pv.param_value == pytest.approx(0.25)
    assert (pv.param_count, pv.param_index, pv.param_type) == (len(PARAMS), 0, mavlink.MAV_PARAM_TYPE_REAL32)
    slow = goto_duration_s(world, 0.0)
    assert slow == pytest.approx(2.0 * fast, rel=0.1)


def test_param_set_out_of_range_answers_the_old_value(world: World) -> None:
    pv = param_set(world.gcs, "DOCK_REACH", -3.0)
    assert pv.param_value == 2.0
    assert world.vehicle.params.dock_reach_m == 2.0
    assert "DOCK_REACH" in world.gcs.received("STATUSTEXT")[-1].text
    pv = param_set(world.gcs, "SYSID_THISMAV", 7.0)
    assert (pv.param_value, pv.param_type) == (7.0, mavlink.MAV_PARAM_TYPE_INT32)


def test_param_list_and_read_by_name_or_index(world: World) -> None:
    gcs = world.gcs
    mark = len(gcs.inbox)
    gcs.send(mavlink.MAVLink_param_request_list_message(SYSID, 1))
    world.clock.sleep(0.0)
    values = gcs.received("PARAM_VALUE", mark)
    assert [v.param_index for v in values] == list(range(len(PARAMS)))
    assert [v.param_id for v in values] == [s.name for s in PARAMS]
    assert {v.param_count for v in values} == {len(PARAMS)}
    mark = len(gcs.inbox)
    gcs.send(mavlink.MAVLink_param_request_read_message(SYSID, 1, b"WP_RADIUS", -1))
    gcs.send(mavlink.MAVLink_param_request_read_message(SYSID, 1, b"", 1))
    world.clock.sleep(0.0)
    got = gcs.received("PARAM_VALUE", mark)
    assert [(v.param_id, v.param_value) for v in got] == [("WP_RADIUS", 1.0), ("ACCEL_MAX", 0.25)]


# ---------------------------------------------------------------------------- docking


def test_dock_a_nearby_mussel_deny_a_far_one_then_undock(world: World) -> None:
    gcs = world.gcs
    gcs.mussel(24, 1.0, 0.5)
    gcs.mussel(25, 10.0, 0.0)
    mark = len(gcs.inbox)
    far = gcs.command_long(MAV_CMD_APAD_DOCK, 1, 25)
    assert (far.result, far.result_param2) == (DENIED, Refusal.OUT_OF_REACH)
    assert gcs.received("STATUSTEXT", mark)[-1].text == "Dock slot 1 aMussel 25: out of docking reach"
    unknown = gcs.command_long(MAV_CMD_APAD_DOCK, 1, 77)
    assert (unknown.result, unknown.result_param2) == (DENIED, Refusal.UNKNOWN_MUSSEL)

    mark = len(gcs.inbox)
    t0 = world.clock.time()
    assert gcs.command_long(MAV_CMD_APAD_DOCK, 2, 24).result == ACCEPTED
    closing = gcs.slot(2, mark)
    assert (closing.mussel_id, closing.latch, closing.charging) == (24, Latch.CLOSING, 0)
    latched = gcs.wait_for("DOCK_SLOT_STATUS", lambda m: m.slot == 2 and m.latch == Latch.LATCHED, 15.0)
    assert world.clock.time() - t0 == pytest.approx(10.0, abs=0.15)
    assert (latched.mussel_id, latched.charging) == (24, 1)
    status = gcs.received("PRIMITIVE_STATUS")[-1]
    assert (status.primitive, status.progress, status.slot, status.mussel_id) == (Primitive.DOCK, Progress.DONE, 2, 24)

    t0 = world.clock.time()
    assert gcs.command_long(MAV_CMD_APAD_UNDOCK, 2, 24).result == ACCEPTED
    assert gcs.slot(2).latch == Latch.RELEASING
    empty = gcs.wait_for("DOCK_SLOT_STATUS", lambda m: m.slot == 2 and m.latch == Latch.OPEN, 10.0)
    assert world.clock.time() - t0 == pytest.approx(5.0, abs=0.15)
    assert (empty.mussel_id, empty.charging) == (0, 0)
    assert gcs.command_long(MAV_CMD_APAD_UNDOCK, 2, 0).result_param2 == Refusal.SLOT_EMPTY


def test_retransmitted_dock_and_undock_are_harmless(world: World) -> None:
    gcs = world.gcs
    gcs.mussel(24, 0.5, 0.0)
    gcs.mussel(31, -0.5, 0.0)
    assert gcs.command_long(MAV_CMD_APAD_DOCK, 1, 31).result == ACCEPTED
    assert gcs.command_long(MAV_CMD_APAD_DOCK, 2, 24).result == ACCEPTED
    world.clock.sleep(1.0)
    mark = len(gcs.inbox)
    # The ACK was lost: the GCS sends the same command again.
    assert gcs.command_long(MAV_CMD_APAD_DOCK, 2, 24).result == ACCEPTED
    assert gcs.received_slot(2, mark) == []  # nothing changed, nothing announced
    gcs.wait_for("DOCK_SLOT_STATUS", lambda m: m.slot == 2 and m.latch == Latch.LATCHED, 10.0)
    world.clock.sleep(20.0)
    # Long after, the same dock again: still latched, never re-docked.
    mark = len(gcs.inbox)
    assert gcs.command_long(MAV_CMD_APAD_DOCK, 2, 24).result == ACCEPTED
    assert {m.latch for m in gcs.received_slot(2, mark)} <= {Latch.LATCHED}

    param_set(gcs, "UNDOCK_TIME", 1.0)
    assert gcs.command_long(MAV_CMD_APAD_UNDOCK, 2, 0).result == ACCEPTED
    world.clock.sleep(2.0)  # released and empty
    retry = gcs.command_long(MAV_CMD_APAD_UNDOCK, 2, 0)  # a late retry of that undock: re-ACKed
    assert (retry.result, retry.result_param2) == (ACCEPTED, 0)
    world.clock.sleep(60.0)
    # No time window: while the undock is what the aPad last did, the same bytes get the first answer.
    again = gcs.command_long(MAV_CMD_APAD_UNDOCK, 2, 0)
    assert (again.result, again.result_param2) == (ACCEPTED, 0)
    world.clock.sleep(2.0)
    assert gcs.slot(1).latch == Latch.LATCHED and gcs.slot(1).mussel_id == 31
    assert gcs.slot(2).latch == Latch.OPEN
    # Once something else ran, the same bytes are a new command, and it finds the slot empty.
    assert gcs.command_long(mavlink.MAV_CMD_DO_SET_MODE, 1, 4)  # HOLD.result == ACCEPTED
    fresh = gcs.command_long(MAV_CMD_APAD_UNDOCK, 2, 0)
    assert (fresh.result, fresh.result_param2) == (DENIED, Refusal.SLOT_EMPTY)
    events = [json.loads(line) for line in world.vehicle.log.events_path.read_text().splitlines()]  # type: ignore[union-attr]
    retries = [e["command"] for e in events if e["event"] == "command_retry"]
    assert retries == [MAV_CMD_APAD_DOCK, MAV_CMD_APAD_DOCK, MAV_CMD_APAD_UNDOCK, MAV_CMD_APAD_UNDOCK]


def test_a_go_to_resent_after_the_failsafe_took_over_is_executed_again(world: World) -> None:
    """The seed-6 livelock: the ACK of a Go To is lost, the failsafe switches to Hold, and the GCS's
    re-send (the same bytes) must start the Go To again, not be answered as a duplicate."""
    gcs = world.gcs
    assert gcs.reposition(20.0, 0.0).result == ACCEPTED
    world.clock.sleep(1.0)
    world.vehicle.modes.enter_hold()  # what the failsafe does
    assert world.vehicle.primitive.kind == Primitive.HOLD
    assert gcs.reposition(20.0, 0.0).result == ACCEPTED
    assert world.vehicle.primitive.kind == Primitive.GOTO
    assert gcs.reposition(20.0, 0.0).result == ACCEPTED  # a duplicate of that: nothing restarts
    events = [json.loads(line) for line in world.vehicle.log.events_path.read_text().splitlines()]  # type: ignore[union-attr]
    assert [e["event"] for e in events if e["event"] in ("command", "command_retry")][-3:] == [
        "command", "command", "command_retry"]


def test_a_datagram_the_network_duplicated_is_never_executed_twice_even_after_a_hold(world: World) -> None:
    """A re-send (a new frame) of a Go To after a Hold is a new command; the very same frame coming
    late (a duplicated datagram) is not, whatever happened in between."""
    gcs = world.gcs
    lat_e7, lon_e7 = latlon_e7(20.0, 0.0)
    frame = gcs.codec.encode(mavlink.MAVLink_command_int_message(
        SYSID, 1, mavlink.MAV_FRAME_GLOBAL_INT, mavlink.MAV_CMD_DO_REPOSITION, 0, 0,
        -1.0, mavlink.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, 0.0, math.nan, lat_e7, lon_e7, 0.0))
    mark = len(gcs.inbox)
    gcs.transport.send(frame)
    assert gcs.ack(mavlink.MAV_CMD_DO_REPOSITION, mark).result == ACCEPTED
    assert gcs.command_long(mavlink.MAV_CMD_DO_SET_MODE, 1, 4).result == ACCEPTED  # HOLD
    assert world.vehicle.primitive.kind == Primitive.HOLD
    mark = len(gcs.inbox)
    gcs.transport.send(frame)  # the duplicate, late
    assert gcs.ack(mavlink.MAV_CMD_DO_REPOSITION, mark).result == ACCEPTED  # answered as the first time
    assert world.vehicle.primitive.kind == Primitive.HOLD  # and not executed again
    assert gcs.reposition(20.0, 0.0).result == ACCEPTED  # a re-send: a new frame, executed
    assert world.vehicle.primitive.kind == Primitive.GOTO


def test_a_mussel_drifting_away_mid_dock_fails_it(world: World) -> None:
    gcs = world.gcs
    gcs.mussel(5, 1.0, 0.0)
    assert gcs.command_long(MAV_CMD_APAD_DOCK, 3, 5).result == ACCEPTED
    world.clock.sleep(4.0)
    gcs.mussel(5, 4.0, 0.0)
    failed = gcs.wait_for("PRIMITIVE_STATUS", lambda m: m.progress == Progress.FAILED, 1.0)
    assert (failed.primitive, failed.slot) == (Primitive.DOCK, 3)
    assert gcs.slot(3).latch == Latch.OPEN
    assert "failed" in gcs.received("STATUSTEXT")[-1].text


def test_a_mussel_docked_elsewhere_is_refused(world: World) -> None:
    world.gcs.mussel(6, 0.0, 0.0, MusselState.DOCKED)
    ack = world.gcs.command_long(MAV_CMD_APAD_DOCK, 1, 6)
    assert (ack.result, ack.result_param2) == (DENIED, Refusal.ALREADY_DOCKED)


# ---------------------------------------------------------------------------- requests, missions, ftp, logs


def test_request_message_answers_home_and_version(world: World) -> None:
    gcs = world.gcs
    mark = len(gcs.inbox)
    assert gcs.command_long(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_HOME_POSITION).result == ACCEPTED
    home = gcs.wait_for("HOME_POSITION", since=mark, timeout_s=0.1)
    assert (home.latitude, home.longitude) == (439400000, 154400000)
    version_id = mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION
    assert gcs.command_long(mavlink.MAV_CMD_REQUEST_MESSAGE, version_id).result == ACCEPTED
    version = gcs.wait_for("AUTOPILOT_VERSION", since=mark, timeout_s=0.1)
    assert version.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2
    assert version.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
    assert gcs.command_long(mavlink.MAV_CMD_REQUEST_MESSAGE, 12345).result == DENIED


def test_set_message_interval_changes_a_rate_and_disables_it(world: World) -> None:
    gcs = world.gcs
    gpi = mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT
    assert gcs.command_long(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, gpi, 100_000).result == ACCEPTED
    mark = len(gcs.inbox)
    world.clock.sleep(2.0)
    assert len(gcs.received("GLOBAL_POSITION_INT", mark)) == pytest.approx(20, abs=1)
    assert gcs.command_long(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, gpi, -1).result == ACCEPTED
    mark = len(gcs.inbox)
    world.clock.sleep(2.0)
    assert gcs.received("GLOBAL_POSITION_INT", mark) == []
    vfr = mavlink.MAVLINK_MSG_ID_VFR_HUD
    assert gcs.command_long(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, vfr, 500_000).result == ACCEPTED
    world.clock.sleep(2.0)
    assert len(gcs.received("VFR_HUD", mark)) == pytest.approx(4, abs=1)
    assert gcs.command_long(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, gpi, 0).result == ACCEPTED  # default again
    mark = len(gcs.inbox)
    world.clock.sleep(2.0)
    assert len(gcs.received("GLOBAL_POSITION_INT", mark)) == pytest.approx(8, abs=1)


def test_missions_are_empty_ftp_is_nakked_and_gcs_heartbeats_are_recorded(world: World) -> None:
    gcs = world.gcs
    mark = len(gcs.inbox)
    gcs.send(mavlink.MAVLink_mission_request_list_message(SYSID, 1, 0))
    # An FTP OpenFileRO of @PARAM/param.pck: seq 5, session 0, opcode 4.
    ftp = bytes([5, 0, 0, 4, 17, 0, 0, 0, 0, 0, 0, 0]) + b"@PARAM/param.pck"
    gcs.send(mavlink.MAVLink_file_transfer_protocol_message(0, SYSID, 1, list(ftp.ljust(251, b"\0"))))
    gcs.send(mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3))
    world.clock.sleep(0.0)
    count = gcs.wait_for("MISSION_COUNT", since=mark, timeout_s=0.1)
    assert (count.count, count.target_system, count.target_component) == (0, 250, 190)
    reply = bytes(gcs.wait_for("FILE_TRANSFER_PROTOCOL", since=mark, timeout_s=0.1).payload)
    assert reply[0] | reply[1] << 8 == 6  # seq + 1
    assert (reply[3], reply[4], reply[5], reply[12]) == (129, 1, 4, 10)  # NAK, size 1, to OpenFileRO, FileNotFound
    assert world.vehicle.last_gcs_heartbeat_us == world.clock.now_us


def test_gcs_failsafe_holds_when_enabled_and_the_gcs_goes_quiet(tmp_path: Path) -> None:
    w = World(tmp_path, ApadParams(fs_gcs_enable=1, fs_gcs_timeout_s=3.0))
    gcs = w.gcs
    gcs.send(mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3))
    gcs.reposition(200.0, 0.0)
    hold = gcs.wait_for("PRIMITIVE_STATUS", lambda m: m.primitive == Primitive.HOLD, 10.0)
    assert hold.time_us / 1e6 == pytest.approx(3.1, abs=0.15)
    assert "failsafe" in gcs.received("STATUSTEXT")[-1].text
    w.vehicle.close()


def test_tlog_and_event_log_are_written_and_readable(world: World, tmp_path: Path) -> None:
    gcs = world.gcs
    gcs.mussel(24, 1.0, 0.0)
    gcs.command_long(MAV_CMD_APAD_DOCK, 1, 24)
    gcs.reposition(5.0, 5.0)
    world.clock.sleep(20.0)
    sent, received = world.vehicle.codec.stats.sent, world.vehicle.codec.stats.received
    world.vehicle.close()
    world.vehicle.close()  # idempotent

    # Re-parse with a Codec: every record is an 8-byte big-endian stamp plus one frame.
    data = (tmp_path / "apad1.tlog").read_bytes()
    parser, stamps, msgs = Codec(255, 0), [], []
    i = 0
    while i < len(data):
        stamps.append(int.from_bytes(data[i:i + 8], "big"))
        length = data[i + 9]  # MAVLink 2: magic, len
        frame = data[i + 8:i + 8 + 12 + length]
        msgs.extend(parser.decode(frame))
        i += 8 + 12 + length
    assert len(msgs) == sent + received and parser.stats.bad_data == 0
    assert stamps == sorted(stamps) and stamps[-1] == pytest.approx(21e6, abs=1e5)
    types = {m.get_type() for m in msgs}
    assert {"COMMAND_LONG", "COMMAND_INT", "AMUSSEL_STATUS", "COMMAND_ACK", "DOCK_SLOT_STATUS"} <= types

    # pymavlink's own reader (as mavlogdump uses) with our dialect, in a clean process.
    script = (
        "import os, sys, json\n"
        "os.environ['MAVLINK20'] = '1'\n"
        "import mavlink_dialect.subcultron as mod, pymavlink.dialects.v20 as pkg\n"
        "sys.modules['pymavlink.dialects.v20.subcultron'] = mod; pkg.subcultron = mod\n"
        "from pymavlink import mavutil\n"
        "m = mavutil.mavlink_connection(sys.argv[1], dialect='subcultron')\n"
        "n = {}\n"
        "while (msg := m.recv_msg()) is not None: n[msg.get_type()] = n.get(msg.get_type(), 0) + 1\n"
        "print(json.dumps(n))\n"
    )
    out = subprocess.run([sys.executable, "-c", script, str(tmp_path / "apad1.tlog")],
                         capture_output=True, text=True, timeout=30, check=True)
    counts = json.loads(out.stdout)
    assert sum(counts.values()) == len(msgs)
    assert counts["DOCK_SLOT_STATUS"] == sum(m.get_type() == "DOCK_SLOT_STATUS" for m in msgs)

    events = [json.loads(line) for line in (tmp_path / "apad1.events.jsonl").read_text().splitlines()]
    kinds = [e["event"] for e in events]
    assert kinds[0] == "start" and kinds[-1] == "close"
    commands = [e for e in events if e["event"] == "command"]
    assert [c["name"] for c in commands] == ["MAV_CMD_APAD_DOCK", "MAV_CMD_DO_REPOSITION"]
    assert {"primitive", "slot", "mode"} <= set(kinds)
    assert all(a["t_s"] <= b["t_s"] for a, b in pairwise(events))


# ---------------------------------------------------------------------------- real UDP, wall clock



def test_real_time_over_udp_sockets(tmp_path: Path) -> None:
    port = free_udp_port()
    clock = WallClock(Scheduler())
    vehicle = SitlVehicle(open_transport(f"udp:127.0.0.1:{port}", listen=True), ApadParams(), *HOME,
                          system_id=SYSID, log_dir=tmp_path)
    vehicle.attach(clock.scheduler, clock.now_us)
    gcs = Gcs(open_transport(f"udp:127.0.0.1:{port}", listen=False), clock)
    clock.scheduler.add_poller(gcs)
    try:
        # The vehicle answers whoever it has heard: say hello first.
        gcs.send(mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3))
        hb = gcs.wait_for("HEARTBEAT", timeout_s=3.0)
        assert hb.type == mavlink.MAV_TYPE_SURFACE_BOAT
        ack = gcs.reposition(2.0, 0.0)
        assert ack.result == ACCEPTED
        clock.sleep(1.5)
        gpi = gcs.received("GLOBAL_POSITION_INT")
        assert len(gpi) >= 5  # 4 Hz in real time
        assert gpi[-1].vy > 0  # moving east (NED: vy is east)
        assert vehicle.last_gcs_heartbeat_us is not None
    finally:
        vehicle.close()
        gcs.transport.close()
