"""The SITL aPad's state (apad_sitl.state) changed one way: every change of mode and arming is told to
its listeners (the "mode" event and the heartbeat), a checkpoint's restore alone is silent, and the
parked physics is settled by the state's own accessors, so no caller has to.

A real `SitlVehicle` on a virtual clock, driven over real MAVLink bytes from a GCS codec; its
heartbeat stream is off, so every HEARTBEAT the GCS hears is one a change sent.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

from apad_sitl import primitives as prim
from apad_sitl.endpoint import DEFAULT_RATES_HZ, SitlVehicle
from apad_sitl.energy_counters import EnergyCounters
from apad_sitl.params import ApadParams
from apad_sitl.vehicle import VehicleState
from apad_sitl.vocabulary import RoverMode
from mavlink_dialect import Codec, mavlink, memory_pair
from missiontime import Scheduler, VirtualClock
from mussel_sim.geo import LocalFrame

HOME = (43.94, 15.44)
ARMED = mavlink.MAV_MODE_FLAG_SAFETY_ARMED


class Bench:
    """One SITL aPad and the GCS end of its link; `heard()` decodes what the aPad sent since."""

    def __init__(self, log_dir: Path) -> None:
        self.apad_end, self.gcs_end = memory_pair()
        self.clock = VirtualClock(Scheduler())
        self.vehicle = SitlVehicle(self.apad_end, ApadParams(fs_gcs_timeout_s=5.0), *HOME, log_dir=log_dir,
                                   rates_hz={mavlink.MAVLINK_MSG_ID_HEARTBEAT: 0.0})
        self.events_path = log_dir / "apad1.events.jsonl"
        self.gcs = Codec(250, 190)
        self.reader = Codec(251, 191)  # decodes what the aPad sent (a codec of its own: no sequence mix-up)
        self.vehicle.attach(self.clock.scheduler)
        self.clock.sleep(0.5)
        self.heard()

    def send(self, msg: mavlink.MAVLink_message, then_s: float = 0.5) -> None:
        self.gcs_end.send(self.gcs.encode(msg))
        self.clock.sleep(then_s)

    def heard(self, msg_type: str | None = None) -> list[Any]:
        msgs = [m for frame in self.gcs_end.receive() for m in self.reader.decode(frame)]
        return [m for m in msgs if msg_type is None or m.get_type() == msg_type]

    def events(self, *names: str) -> list[dict[str, Any]]:
        assert self.vehicle.log is not None
        self.vehicle.log.flush()
        lines = [json.loads(line) for line in self.events_path.read_text().splitlines()]
        return [e for e in lines if e["event"] in names]


def _command(command: int, *params: float) -> mavlink.MAVLink_message:
    p = [*params, *[0.0] * (7 - len(params))]
    return mavlink.MAVLink_command_long_message(1, 1, command, 0, *p)


def _go_to(x_m: float, y_m: float) -> mavlink.MAVLink_message:
    lat, lon = LocalFrame(*HOME).to_geodetic(x_m, y_m)
    return mavlink.MAVLink_command_int_message(
        1, 1, mavlink.MAV_FRAME_GLOBAL_INT, mavlink.MAV_CMD_DO_REPOSITION, 0, 0, -1.0,
        mavlink.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, 0.0, math.nan, round(float(lat) * 1e7), round(float(lon) * 1e7),
        0.0)


def _gcs_heartbeat() -> mavlink.MAVLink_message:
    return mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3)


@pytest.fixture
def b(tmp_path: Path) -> Iterator[Bench]:
    bench = Bench(tmp_path)
    yield bench
    bench.vehicle.close()


def test_every_way_the_mode_and_arming_change_is_told_and_none_other_is_left(b: Bench) -> None:
    custom = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    ways: list[tuple[str, Any]] = [
        ("DO_SET_MODE", lambda: b.send(_command(mavlink.MAV_CMD_DO_SET_MODE, custom, RoverMode.GUIDED))),
        ("SET_MODE", lambda: b.send(mavlink.MAVLink_set_mode_message(1, custom, RoverMode.HOLD))),
        ("a Go To", lambda: b.send(_go_to(20.0, 0.0))),
        ("the failsafe", lambda: b.clock.sleep(6.0)),  # heard below, then silent past FS_GCS_TIMEOUT: HOLD
        ("ApadState.set_mode", lambda: b.vehicle.apad.set_mode(RoverMode.GUIDED)),
    ]
    b.send(_gcs_heartbeat(), then_s=0.0)
    told = []
    for way, change in ways:
        before = b.vehicle.mode
        change()
        assert b.vehicle.mode != before, way
        told.append([(hb.custom_mode, way) for hb in b.heard("HEARTBEAT")])
    assert told == [[(RoverMode.GUIDED, "DO_SET_MODE")], [(RoverMode.HOLD, "SET_MODE")],
                    [(RoverMode.GUIDED, "a Go To")], [(RoverMode.HOLD, "the failsafe")],
                    [(RoverMode.GUIDED, "ApadState.set_mode")]]
    assert [e["mode"] for e in b.events("mode")] == ["GUIDED", "HOLD", "GUIDED", "HOLD", "GUIDED"]

    b.send(_command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0.0))
    b.vehicle.apad.set_armed(True)
    assert [hb.base_mode & ARMED for hb in b.heard("HEARTBEAT")] == [0, ARMED]
    assert [e["event"] for e in b.events("arm", "disarm")] == ["disarm", "arm"]

    # No way around the listeners: the state and the vehicle refuse a plain assignment.
    with pytest.raises(AttributeError):
        b.vehicle.apad.mode = RoverMode.HOLD  # type: ignore[misc]
    with pytest.raises(AttributeError):
        b.vehicle.apad.armed = False  # type: ignore[misc]
    with pytest.raises(AttributeError):
        b.vehicle.mode = RoverMode.HOLD  # type: ignore[misc]
    with pytest.raises(AttributeError):
        b.vehicle.armed = False  # type: ignore[misc]
    assert (b.vehicle.mode, b.vehicle.armed, b.heard("HEARTBEAT")) == (RoverMode.GUIDED, True, [])


def test_a_restore_sets_mode_arming_and_the_rest_silently_and_announces_the_primitive(b: Bench) -> None:
    apad = b.vehicle.apad
    counters = EnergyCounters(passed_wh=12.5, drawn_wh=20.0, home_wh=3.0, home_charges=2)
    primitive = prim.go_to(apad.primitive, 30.0, -5.0)
    events_before = len(b.events("mode", "arm", "disarm", "primitive"))

    apad.restore(VehicleState(x_m=4.0, y_m=2.0, battery_v=13.0), primitive, RoverMode.GUIDED, False, 0.4, counters)
    sent = b.heard()
    assert (apad.mode, apad.armed, apad.speed_override_mps, apad.primitive) == (RoverMode.GUIDED, False, 0.4,
                                                                                  primitive)
    assert apad.energy is counters and (apad.state.x_m, apad.state.battery_v) == (4.0, 13.0)
    assert [m.get_type() for m in sent if m.get_type() == "HEARTBEAT"] == []  # mode and arming: not announced
    assert [m.get_type() for m in sent if m.get_type() == "PRIMITIVE_STATUS"] == ["PRIMITIVE_STATUS"]
    assert [e["event"] for e in b.events("mode", "arm", "disarm", "primitive")[events_before:]] == ["primitive"]


def _settled_by_the_state(park: bool, log_dir: Path) -> tuple[list[tuple[Any, ...]], dict[str, bytes], list[bool]]:
    """Charging at the home charger with the physics parked, then the parameters, the arming and the
    current written, and the hull and energy counters read, through `ApadState` alone, between ticks."""
    apad_end, _ = memory_pair()
    clock = VirtualClock(Scheduler())
    # No telemetry: nothing else settles between the script's reads, so the writes find ticks skipped.
    vehicle = SitlVehicle(apad_end, ApadParams(fs_gcs_enable=0), *HOME, park_at_rest=park, log_dir=log_dir,
                          rates_hz=dict.fromkeys(DEFAULT_RATES_HZ, 0.0))
    apad = vehicle.apad
    apad.state = VehicleState(battery_v=14.0)
    reads: list[tuple[Any, ...]] = []
    parked_at_writes: list[bool] = []

    def script(now_us: int) -> None:  # before the aPad's tasks in each instant's order; every 50 ms
        step = now_us // 50_000
        if step in (401, 801, 1201):
            assert vehicle.physics is not None
            parked_at_writes.append(vehicle.physics.parked)
        if step == 401:  # 20.05 s: between two physics ticks
            apad.params = replace(apad.params, home_charge_w=400.0)
        if step == 801:
            apad.set_armed(False)
        if step == 1201:
            apad.current_mps = (0.05, 0.0)
        if step % 14 == 0:
            reads.append((now_us, apad.energy.home_wh, apad.energy.charging, apad.state))

    clock.scheduler.every(0.05, script, "script")
    vehicle.attach(clock.scheduler)
    clock.sleep(90.0)
    vehicle.close()
    return reads, {p.name: p.read_bytes() for p in sorted(log_dir.iterdir())}, parked_at_writes


def test_the_parked_physics_is_settled_by_the_state_s_own_reads_and_writes(tmp_path: Path) -> None:
    ticking = _settled_by_the_state(False, tmp_path / "ticking")
    parked = _settled_by_the_state(True, tmp_path / "parked")
    assert parked[2] == [True] * 3 and ticking[2] == [False] * 3  # each write found the physics parked
    assert parked[0] == ticking[0] and len(parked[0]) > 100
    assert parked[1] == ticking[1]  # the .tlog and event log to the byte
    reads = parked[0]
    assert reads[-1][1] > reads[len(reads) // 4][1] > 0.0  # charged at home throughout the run
    assert reads[-1][3].x_m > 0.1  # the current set at 60 s moved the hull
