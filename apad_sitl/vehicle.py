"""Kinematic model of the omnidirectional aPad: bounded speed and acceleration, current, heading, battery.

The thrusters (four in X) act in any direction, so the model tracks a water-relative velocity
setpoint directly, limited by ACCEL_MAX; the water current then carries the hull over ground.
Nothing here reads a clock or does I/O: `dt_s` is an argument.

Battery: 16.0 V full, 10.5 V empty, draining linearly in time at
    BATT_DRAIN_IDLE + BATT_DRAIN_THR * thrust^2   [V/h]
where thrust is the specific force the thrusters deliver [m/s^2]: the change of water-relative
velocity plus the linear drag THR_DRAG * water velocity. Holding still in slack water costs the
hotel load only; cruising, accelerating and fighting a current cost more. At 10.5 V the
thrusters stop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from apad_sitl.params import ApadParams

BATTERY_FULL_V = 16.0
BATTERY_EMPTY_V = 10.5
VOLT_RANGE = BATTERY_FULL_V - BATTERY_EMPTY_V  # the battery's energy is linear in voltage over this
# Below this water speed the bow keeps its heading instead of chasing a noisy direction.
HEADING_MIN_SPEED_MPS = 0.05
TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class VehicleState:
    x_m: float = 0.0  # m, east of home
    y_m: float = 0.0  # m, north of home
    vx_mps: float = 0.0  # m/s, east, over ground (what GPS measures)
    vy_mps: float = 0.0  # m/s, north, over ground
    water_vx_mps: float = 0.0  # m/s, east, through the water (what the thrusters control)
    water_vy_mps: float = 0.0  # m/s, north, through the water
    heading_rad: float = 0.0  # rad, clockwise from north, in [0, 2 pi)
    yaw_rate_radps: float = 0.0  # rad/s, clockwise positive, over the last step
    thrust_mps2: float = 0.0  # m/s^2, specific force of the thrusters over the last step
    battery_v: float = BATTERY_FULL_V  # V, 16.0 full .. 10.5 empty
    distance_travelled_m: float = 0.0  # m, integral of ground speed

    @property
    def ground_speed_mps(self) -> float:
        return math.hypot(self.vx_mps, self.vy_mps)

    @property
    def battery_frac(self) -> float:
        """0 (10.5 V) .. 1 (16.0 V)."""
        return (self.battery_v - BATTERY_EMPTY_V) / (BATTERY_FULL_V - BATTERY_EMPTY_V)


def wrap_pi(angle_rad: float) -> float:
    """`angle_rad` in [-pi, pi)."""
    return (angle_rad + math.pi) % TWO_PI - math.pi


def _snap(v_mps: float) -> float:
    """Flush velocities that decayed to nothing to 0: denormal floats are slow and meaningless."""
    return 0.0 if -1e-12 < v_mps < 1e-12 else v_mps


def drain_v(params: ApadParams, thrust_mps2: float, dt_s: float) -> float:
    """Volts the battery loses in `dt_s` seconds at this thrust: the hotel load plus the thrusters'."""
    return (params.batt_drain_idle_vph + params.batt_drain_thrust_vph * thrust_mps2 * thrust_mps2) * dt_s / 3600.0


def step(
    state: VehicleState,
    velocity_setpoint_mps: tuple[float, float],  # (east, north), water-relative
    params: ApadParams,
    current_mps: tuple[float, float],  # (east, north), water over ground
    dt_s: float,
) -> VehicleState:
    """Advance the vehicle by `dt_s` seconds."""
    if dt_s <= 0.0:
        return state
    sx, sy = velocity_setpoint_mps
    if state.battery_v <= BATTERY_EMPTY_V:
        sx = sy = 0.0  # flat battery: thrusters off, the hull drifts and drag stops it
    speed = math.hypot(sx, sy)
    if speed > params.speed_max_mps:
        sx, sy = sx * params.speed_max_mps / speed, sy * params.speed_max_mps / speed

    dvx, dvy = sx - state.water_vx_mps, sy - state.water_vy_mps
    dv = math.hypot(dvx, dvy)
    dv_max = params.accel_max_mps2 * dt_s
    if dv > dv_max:
        dvx, dvy = dvx * dv_max / dv, dvy * dv_max / dv
    wvx, wvy = _snap(state.water_vx_mps + dvx), _snap(state.water_vy_mps + dvy)

    thrust = math.hypot(dvx / dt_s + params.drag_per_s * wvx, dvy / dt_s + params.drag_per_s * wvy)
    if state.battery_v <= BATTERY_EMPTY_V:
        thrust = 0.0  # slowing down is drag's work, not the thrusters'
    drain = drain_v(params, thrust, dt_s)

    gvx, gvy = wvx + current_mps[0], wvy + current_mps[1]

    heading = state.heading_rad
    if math.hypot(wvx, wvy) > HEADING_MIN_SPEED_MPS:
        error = wrap_pi(math.atan2(wvx, wvy) - heading)  # atan2(east, north): compass bearing
        turn_max = math.radians(params.yaw_rate_max_dps) * dt_s
        heading += max(-turn_max, min(turn_max, error))
    heading %= TWO_PI
    yaw_rate = wrap_pi(heading - state.heading_rad) / dt_s

    return VehicleState(
        x_m=state.x_m + gvx * dt_s,
        y_m=state.y_m + gvy * dt_s,
        vx_mps=gvx,
        vy_mps=gvy,
        water_vx_mps=wvx,
        water_vy_mps=wvy,
        heading_rad=heading,
        yaw_rate_radps=yaw_rate,
        thrust_mps2=thrust,
        battery_v=max(BATTERY_EMPTY_V, state.battery_v - drain),
        distance_travelled_m=state.distance_travelled_m + math.hypot(gvx, gvy) * dt_s,
    )
