"""Go To Point over MAVLink: DO_REPOSITION (what MAVSDK's goto_location and MAVProxy's guided send)
and DO_CHANGE_SPEED.

A Go To switches to GUIDED and starts the Go To primitive. Refused: a frame that is not global,
coordinates that are no coordinates, (0, 0) (an unset position, not the Gulf of Guinea), a target
further than MAX_GOTO_FROM_HOME_M from home, and one outside the geofence.
"""

from __future__ import annotations

import math

from apad_sitl import primitives as prim
from apad_sitl.dege7 import DegE7
from apad_sitl.geofence import Geofence
from apad_sitl.host import ACCEPT, DENY, Command, CommandRegistry, PartHost, Reply, invalid
from apad_sitl.state import ApadState
from apad_sitl.vocabulary import RoverMode
from mavlink_dialect import mavlink
from mussel_sim.geo import LocalFrame

# A Go To further than this from home is a typo in the coordinates, not a mission.
MAX_GOTO_FROM_HOME_M = 20_000.0
GLOBAL_FRAMES = frozenset({
    mavlink.MAV_FRAME_GLOBAL,
    mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
    mavlink.MAV_FRAME_GLOBAL_INT,
    mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
})
SPEED_NO_CHANGE = -1.0  # DO_CHANGE_SPEED param2, MAVLink's
SPEED_DEFAULT = -2.0


class Navigation:
    """The vehicle's Go To part. The speed override is the aPad's state (`ApadState.speed_override_mps`).

    `frame` turns targets into local metres; `geofence` (None: none) is the water a target must be in;
    a Go To remembers its target as commanded in `target_e7`, which telemetry echoes.
    """

    def __init__(
        self,
        host: PartHost,
        apad: ApadState,
        commands: CommandRegistry,
        frame: LocalFrame,
        geofence: Geofence | None,
        target_e7: DegE7,
    ) -> None:
        self._host = host
        self._apad = apad
        self._frame = frame
        self._geofence = geofence
        self._target_e7 = target_e7
        commands.register(mavlink.MAV_CMD_DO_REPOSITION, self._cmd_reposition, stateful=True)
        commands.register(mavlink.MAV_CMD_DO_CHANGE_SPEED, self._cmd_change_speed, stateful=True)

    def _cmd_reposition(self, cmd: Command) -> Reply:
        host, apad = self._host, self._apad
        if cmd.frame is not None and cmd.frame not in GLOBAL_FRAMES:
            return invalid("frame")
        lat, lon = cmd.lat_lon_deg()
        if not (math.isfinite(lat) and -90 <= lat <= 90):
            return invalid(cmd.field(5))
        if not (math.isfinite(lon) and -180 <= lon <= 180):
            return invalid(cmd.field(6))
        # Speed and radius: NaN or <= 0 mean the default (MAVLink's "-1"); an infinity means nothing.
        speed, radius = cmd.params[0], cmd.params[2]
        if math.isinf(speed):
            return invalid(cmd.field(1))
        if math.isinf(radius):
            return invalid(cmd.field(3))
        if lat == 0.0 and lon == 0.0:
            return DENY  # an unset position
        x, y = self._frame.to_local(lat, lon)
        x_m, y_m = float(x), float(y)
        if math.hypot(x_m, y_m) > MAX_GOTO_FROM_HOME_M:
            host.statustext(mavlink.MAV_SEVERITY_WARNING, "Go To refused: target too far from home")
            return DENY
        if self._geofence is not None and not self._geofence.contains(x_m, y_m):
            host.statustext(mavlink.MAV_SEVERITY_WARNING, "Go To refused: target outside the geofence")
            host.event("geofence", what="goto", lat_deg=lat, lon_deg=lon)
            return DENY
        speed = speed if speed > 0 else apad.speed_override_mps  # NaN > 0 is False
        radius = radius if radius > 0 else 0.0
        self._target_e7.remember(x_m, y_m, round(lat * 1e7), round(lon * 1e7))  # echo the target exactly
        apad.set_mode(RoverMode.GUIDED)
        apad.set_primitive(prim.go_to(apad.primitive, x_m, y_m, speed, radius))
        return ACCEPT

    def _cmd_change_speed(self, cmd: Command) -> Reply:
        apad = self._apad
        speed = cmd.params[1]
        if speed == SPEED_NO_CHANGE:
            return ACCEPT
        if speed == SPEED_DEFAULT:
            speed = 0.0
        elif not (math.isfinite(speed) and speed > 0):
            return invalid(cmd.field(2))
        apad.speed_override_mps = speed
        apad.set_primitive(prim.set_speed(apad.primitive, speed))
        return ACCEPT
