"""Navigation alone: `Navigation` on a recording host, an `ApadState`, a registry, the local frame, a
real geofence and the shared target converter; no vehicle, no streams, no modes part.

A Go To (DO_REPOSITION) switches to GUIDED and starts the Go To primitive, remembering its target as
commanded; DO_CHANGE_SPEED sets the speed of later Go Tos; refusals for targets that are none.
"""

from __future__ import annotations

import math

import pytest
from test_sitl_part_host import RecordingHost, Registry

from apad_sitl.dege7 import DegE7
from apad_sitl.geofence import Geofence
from apad_sitl.navigation import Navigation
from apad_sitl.params import ApadParams
from apad_sitl.state import ApadState
from apad_sitl.vocabulary import Primitive, Progress, RoverMode
from mavlink_dialect import mavlink
from mussel_sim.geo import LocalFrame

HOME = (43.94, 15.44)
GOTO, SPEED = mavlink.MAV_CMD_DO_REPOSITION, mavlink.MAV_CMD_DO_CHANGE_SPEED
ACCEPTED, DENIED = mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_DENIED
NAN = math.nan


class Bench:
    def __init__(self, geofence_m: float | None = None) -> None:
        self.host = RecordingHost()
        self.apad = ApadState(ApadParams())
        self.commands = Registry()
        self.frame = LocalFrame(*HOME)
        self.target_e7 = DegE7(self.frame)
        fence = None
        if geofence_m is not None:  # a square of water around home
            d = geofence_m
            fence = Geofence.of([self.latlon(x, y) for x, y in ((-d, -d), (d, -d), (d, d), (-d, d))], self.frame)
        self.navigation = Navigation(self.host, self.apad, self.commands, self.frame, fence, self.target_e7)
        self.modes: list[int] = []
        self.apad.on_mode(self.modes.append)

    def latlon(self, x_m: float, y_m: float) -> tuple[float, float]:
        lat, lon = self.frame.to_geodetic(x_m, y_m)
        return float(lat), float(lon)


@pytest.fixture
def b() -> Bench:
    return Bench()


def test_a_go_to_switches_to_guided_and_goes_where_it_was_told(b: Bench) -> None:
    lat, lon = b.latlon(30.0, -10.0)
    e7 = (round(lat * 1e7), round(lon * 1e7))
    reply = b.commands.run(GOTO, 0.4, 0, 2.5, 0, *e7, frame=mavlink.MAV_FRAME_GLOBAL_INT)
    p = b.apad.primitive
    assert reply.result == ACCEPTED
    assert (b.apad.mode, b.modes) == (RoverMode.GUIDED, [RoverMode.GUIDED])
    assert (p.kind, p.progress, p.speed_mps, p.radius_m) == (Primitive.GOTO, Progress.IN_PROGRESS, 0.4, 2.5)
    assert (p.target_x_m, p.target_y_m) == pytest.approx((30.0, -10.0), abs=0.02)  # degE7: 1 cm
    assert b.target_e7.of(p.target_x_m, p.target_y_m) == e7  # echoed as commanded


def test_the_speed_override_is_the_default_speed_of_later_go_tos(b: Bench) -> None:
    assert b.commands.run(SPEED, 0, 0.7).result == ACCEPTED
    assert b.apad.speed_override_mps == 0.7
    b.commands.run(GOTO, NAN, 0, NAN, 0, *b.latlon(5.0, 5.0))  # COMMAND_LONG: degrees
    assert (b.apad.primitive.speed_mps, b.apad.primitive.radius_m) == (0.7, 0.0)
    assert b.commands.run(SPEED, 0, 0.3).result == ACCEPTED  # and of the running one
    assert b.apad.primitive.speed_mps == 0.3
    assert b.commands.run(SPEED, 0, -2).result == ACCEPTED  # back to SPEED_MAX
    assert b.apad.speed_override_mps == 0.0
    assert b.commands.run(SPEED, 0, -1).result == ACCEPTED  # no change
    assert b.apad.speed_override_mps == 0.0
    assert b.commands.run(SPEED, 0, NAN).invalid == "param2"


def test_targets_that_are_none_are_refused_and_nothing_changes(b: Bench) -> None:
    assert b.commands.run(GOTO, 0, 0, 0, 0, 1, 1, frame=mavlink.MAV_FRAME_LOCAL_NED).invalid == "frame"
    assert b.commands.run(GOTO, 0, 0, 0, 0, NAN, 15.0).invalid == "param5"
    assert b.commands.run(GOTO, 0, 0, 0, 0, 0, 1_900_000_000, frame=mavlink.MAV_FRAME_GLOBAL_INT).invalid == "y"
    assert b.commands.run(GOTO, math.inf, 0, 0, 0, *b.latlon(5.0, 5.0)).invalid == "param1"
    assert b.commands.run(GOTO, 0, 0, 0, 0, 0.0, 0.0).result == DENIED  # an unset position
    assert b.commands.run(GOTO, 0, 0, 0, 0, *b.latlon(30_000.0, 0.0)).result == DENIED
    assert [m.text for m in b.host.take()] == ["Go To refused: target too far from home"]
    assert (b.apad.primitive.kind, b.apad.mode, b.modes) == (Primitive.IDLE, RoverMode.HOLD, [])


def test_a_target_outside_the_geofence_is_refused() -> None:
    b = Bench(geofence_m=100.0)
    assert b.commands.run(GOTO, 0, 0, 0, 0, *b.latlon(50.0, 50.0)).result == ACCEPTED
    lat, lon = b.latlon(150.0, 0.0)
    assert b.commands.run(GOTO, 0, 0, 0, 0, lat, lon).result == DENIED
    assert [m.text for m in b.host.take()] == ["Go To refused: target outside the geofence"]
    assert b.host.events == [("geofence", {"what": "goto", "lat_deg": lat, "lon_deg": lon})]
    assert (b.apad.primitive.target_x_m, b.apad.primitive.target_y_m) == pytest.approx((50.0, 50.0), abs=1e-3)
