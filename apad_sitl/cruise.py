"""A Go To's steady cruise, advanced in closed form: the event platform's hull costs nothing per step while it cruises.

Once a Go To's water velocity equals its setpoint (no acceleration), the setpoint is capped at the Go
To's speed (not yet in the approach zone, where HOLD_KP * dist or sqrt(ACCEL_MAX * dist) fall below
it: `primitives.velocity_setpoint`) and the hull runs straight at its target with its heading aligned,
every step of `vehicle.step` is the same translation, the same odometer increment and the same drain.
`found` tells such a step from the one before it; `Cruise` is the hull n steps on, in closed form, for
at most `limit` steps: it stops short of any step where something discontinuous could happen (the
approach zone, the victory radius, a battery going flat), and the steps from there are stepped.

Stepping makes the same translation to float noise: its velocities wobble by an ulp from step to step
(the setpoint is recomputed from a position rounded each step) and it rounds the position at every
step, where the closed form rounds once (a product for a sum of n terms). Far below what is reported.

Pure: no clock, no I/O. Only on the ideal link (`SitlVehicle(ideal_link=True)`): lockstep steps every tick.
"""

from __future__ import annotations

import math
from dataclasses import replace

from apad_sitl.energy_counters import EnergyCounters
from apad_sitl.home_charger import HOME_STILL_MPS
from apad_sitl.hull_at import HullAt
from apad_sitl.params import ApadParams
from apad_sitl.primitives import PrimitiveState, velocity_setpoint
from apad_sitl.vehicle import BATTERY_EMPTY_V, HEADING_MIN_SPEED_MPS, VehicleState, drain_v, wrap_pi
from apad_sitl.vocabulary import Latch, Primitive, Progress

STEADY_MPS = 1e-14  # a velocity within this of the last step's (and of the next setpoint) is steady: ulps
STEADY_RAD = 1e-12  # the same for the heading
ALIGNED = 1e-9  # the ground track's sideways part per metre travelled, at most: straight at the target
MARGIN_STEPS = 2  # steps a closed form stops short of where the hull could do something else
_TIMED = (Latch.CLOSING, Latch.RELEASING)


class Cruise:
    """The hull cruising since `origin` (the state after the step that found the cruise).

    `steps` counts the steps of `dt_s` taken since, at most `limit`; `state()` is the hull after them.
    """

    __slots__ = ("_drain_v", "_ds_m", "_dx_m", "_dy_m", "_hull", "dt_s", "key", "limit", "origin", "steps")

    def __init__(self, origin: VehicleState, params: ApadParams, dt_s: float, limit: int,
                 key: tuple[object, ...] = ()) -> None:
        self.origin = origin
        self.dt_s = dt_s
        self.limit = limit
        self.key = key  # what it holds for (as a rest's key): a change ends it
        self.steps = 0
        self._dx_m, self._dy_m = origin.vx_mps * dt_s, origin.vy_mps * dt_s  # as `vehicle.step` moves it
        self._ds_m = math.hypot(origin.vx_mps, origin.vy_mps) * dt_s
        self._drain_v = drain_v(params, origin.thrust_mps2, dt_s)
        self._hull = HullAt(origin)

    def take(self, n: int, counters: EnergyCounters) -> int:
        """Up to `n` more steps, no further than `limit`: how many it took (the energy counters do not
        change while cruising: away from home, nothing passed)."""
        taken = max(0, min(n, self.limit - self.steps))
        self.steps += taken
        return taken

    def state(self) -> VehicleState:
        return self._hull.at(self.steps, self.after)

    def after(self, n: int) -> VehicleState:
        """The hull after `n` steps of the cruise (n <= `limit`); changes nothing."""
        o = self.origin
        return replace(o, x_m=o.x_m + n * self._dx_m, y_m=o.y_m + n * self._dy_m,
                       battery_v=max(BATTERY_EMPTY_V, o.battery_v - n * self._drain_v),
                       distance_travelled_m=o.distance_travelled_m + n * self._ds_m)


def found(before: VehicleState, after: VehicleState, primitive: PrimitiveState, params: ApadParams, dt_s: float,
          key: tuple[object, ...] = ()) -> Cruise | None:
    """The cruise a step from `before` to `after` under `primitive` (a Go To, unchanged by the step) found,
    or None if that step was not one of a steady cruise or the cruise would end within a few steps."""
    p = params
    if primitive.kind != Primitive.GOTO or primitive.progress != Progress.IN_PROGRESS:
        return None
    if any(s.latch in _TIMED for s in primitive.slots) or before.battery_v <= BATTERY_EMPTY_V:
        return None  # a latch timer ends at a tick of its own; a flat battery stops the thrusters
    wvx, wvy = after.water_vx_mps, after.water_vy_mps
    if not (abs(wvx - before.water_vx_mps) <= STEADY_MPS and abs(wvy - before.water_vy_mps) <= STEADY_MPS
            and abs(wrap_pi(after.heading_rad - before.heading_rad)) <= STEADY_RAD):
        return None
    sx, sy = velocity_setpoint(primitive, after, p)  # the next step's, capped as `vehicle.step` caps it
    speed = math.hypot(sx, sy)
    if speed > p.speed_max_mps:
        sx, sy = sx * p.speed_max_mps / speed, sy * p.speed_max_mps / speed
    if abs(sx - wvx) > STEADY_MPS or abs(sy - wvy) > STEADY_MPS:
        return None  # still accelerating, or turning toward a target the current pushes it past
    water_mps = math.hypot(wvx, wvy)
    if abs(water_mps - HEADING_MIN_SPEED_MPS) <= STEADY_MPS:
        return None  # the heading's rule could flip from step to step
    if water_mps > HEADING_MIN_SPEED_MPS and abs(wrap_pi(math.atan2(wvx, wvy) - after.heading_rad)) > STEADY_RAD:
        return None  # the bow still turns
    gvx, gvy = after.vx_mps, after.vy_mps
    ground_mps = math.hypot(gvx, gvy)
    if ground_mps <= HOME_STILL_MPS * (1.0 + 1e-6):
        return None  # slow enough to charge at home
    ex, ey = primitive.target_x_m - after.x_m, primitive.target_y_m - after.y_m
    dist = math.hypot(ex, ey)
    toward = (ex * gvx + ey * gvy) / dist if dist > 0.0 else 0.0  # ground speed toward the target
    if toward <= 0.0 or abs(ex * gvy - ey * gvx) > ALIGNED * dist * ground_mps:
        return None  # not straight at the target: the setpoint's direction turns as it goes
    limit = _steps_before_the_end(after, primitive, p, dist, toward * dt_s, dt_s)
    return Cruise(after, p, dt_s, limit, key) if limit > MARGIN_STEPS else None


def _steps_before_the_end(after: VehicleState, primitive: PrimitiveState, p: ApadParams, dist: float,
                          along_m: float, dt_s: float) -> int:
    """How many steps the cruise may take from `after` before the approach zone, the victory radius or a
    flat battery could come within `MARGIN_STEPS` of a step."""
    speed = p.speed_max_mps if primitive.speed_mps <= 0.0 else min(p.speed_max_mps, primitive.speed_mps)
    if p.hold_kp_per_s <= 0.0 or p.accel_max_mps2 <= 0.0:
        return 0
    zone = max(speed / p.hold_kp_per_s, speed * speed / p.accel_max_mps2)  # the setpoint capped beyond it
    radius = primitive.radius_m if primitive.radius_m > 0.0 else p.wp_radius_m
    bound = max(zone, radius) * (1.0 + 1e-6) + 1e-6
    by_distance = math.floor((dist - bound) / along_m) - MARGIN_STEPS
    drain = drain_v(p, after.thrust_mps2, dt_s)
    by_battery = math.floor((after.battery_v - BATTERY_EMPTY_V) / drain) - MARGIN_STEPS if drain > 0.0 else by_distance
    return max(0, min(by_distance, by_battery))
