"""aPad tuning values and their MAVLink parameter names, ranges and descriptions.

`ApadParams` is frozen: a PARAM_SET makes a new one (`with_param`) and the vehicle swaps it in,
so every model step sees one consistent set. The defaults describe a slow 1 m aPad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any


class ParamError(ValueError):
    """An unknown parameter name or a value outside its range; the message is one line."""


@dataclass(frozen=True)
class ApadParams:
    speed_max_mps: float = 0.5  # m/s, water-relative speed bound; also the default Go To speed
    accel_max_mps2: float = 0.25  # m/s^2, bound on the change of water-relative velocity
    wp_radius_m: float = 1.0  # m, default victory radius of Go To (and "arrived" for Hold)
    hold_kp_per_s: float = 0.5  # 1/s, position gain: desired speed per metre of error
    hold_kd: float = 0.5  # dimensionless, ground-velocity-error feedback (rejects current); < 1
    yaw_rate_max_dps: float = 20.0  # deg/s, bound on the heading rate
    dock_reach_m: float = 2.0  # m, horizontal aPad-aMussel distance a dock needs
    dock_time_s: float = 10.0  # s, latch CLOSING -> LATCHED
    undock_time_s: float = 5.0  # s, latch RELEASING -> OPEN
    drag_per_s: float = 0.5  # 1/s, linear drag: thrust to hold a water speed v is drag * v
    batt_drain_idle_vph: float = 0.5  # V/h, hotel load (computer, Kinect, radios)
    batt_drain_thrust_vph: float = 8.0  # V/h per (m/s^2)^2 of thrust (specific force)
    # The energy hub (apad_sitl/energy.py, docs/long_term.md): battery energy over 10.5..16 V, what an
    # aMussel's battery holds over its 0..1, the inductive link's efficiency, the home charger.
    batt_capacity_wh: float = 400.0
    mussel_battery_wh: float = 7.4
    charge_efficiency: float = 0.6
    home_charge_w: float = 150.0
    home_radius_m: float = 2.0
    # 1: hold position when the GCS heartbeat is lost (on by default: a field aPad must not sail on
    # blind; lockstep runs deliver every heartbeat, so they are unaffected)
    fs_gcs_enable: int = 1
    # s without a GCS heartbeat before the failsafe holds; HOLD comes this long after the last one
    fs_gcs_timeout_s: float = 3.0
    sysid_thismav: int = 1  # MAVLink system id; takes effect at restart

    def __post_init__(self) -> None:
        for spec in PARAMS:
            _check(spec, float(getattr(self, spec.field)))


@dataclass(frozen=True)
class ParamSpec:
    name: str  # MAVLink param_id, <= 16 characters
    field: str  # ApadParams field
    min_value: float
    max_value: float
    integral: bool  # sent as MAV_PARAM_TYPE_INT32, else REAL32
    description: str


PARAMS: tuple[ParamSpec, ...] = (
    ParamSpec("SPEED_MAX", "speed_max_mps", 0.05, 3.0, False, "Max water-relative speed and default Go To speed [m/s]"),
    ParamSpec("ACCEL_MAX", "accel_max_mps2", 0.01, 2.0, False, "Max acceleration [m/s^2]"),
    ParamSpec("WP_RADIUS", "wp_radius_m", 0.1, 50.0, False, "Default Go To victory radius [m]"),
    ParamSpec("HOLD_KP", "hold_kp_per_s", 0.01, 5.0, False, "Position gain: desired speed per metre of error [1/s]"),
    ParamSpec("HOLD_KD", "hold_kd", 0.0, 0.9, False, "Ground-velocity-error gain (current rejection), < 1"),
    ParamSpec("YAW_RATE_MAX", "yaw_rate_max_dps", 1.0, 360.0, False, "Max heading rate [deg/s]"),
    ParamSpec("DOCK_REACH", "dock_reach_m", 0.1, 50.0, False, "Max aPad-aMussel distance for docking [m]"),
    ParamSpec("DOCK_TIME", "dock_time_s", 0.0, 600.0, False, "Time the latch takes to close on an aMussel [s]"),
    ParamSpec("UNDOCK_TIME", "undock_time_s", 0.0, 600.0, False, "Time the latch takes to release [s]"),
    ParamSpec("THR_DRAG", "drag_per_s", 0.0, 10.0, False, "Linear drag: thrust per water speed [1/s]"),
    ParamSpec("BATT_DRAIN_IDLE", "batt_drain_idle_vph", 0.0, 100.0, False, "Battery drain of the hotel load [V/h]"),
    ParamSpec("BATT_DRAIN_THR", "batt_drain_thrust_vph", 0.0, 1000.0, False,
              "Battery drain per squared thrust [V/h per (m/s^2)^2]"),
    ParamSpec("BATT_CAPACITY", "batt_capacity_wh", 1.0, 100_000.0, False, "Battery energy, 10.5 to 16 V [Wh]"),
    ParamSpec("MSL_BATT_WH", "mussel_battery_wh", 0.1, 1000.0, False, "An aMussel battery's energy, 0 to 1 [Wh]"),
    ParamSpec("CHG_EFF", "charge_efficiency", 0.05, 1.0, False, "Inductive charging efficiency, aPad to aMussel"),
    ParamSpec("HOME_CHG_W", "home_charge_w", 0.0, 10_000.0, False, "Home charger power; 0: none [W]"),
    ParamSpec("HOME_RADIUS", "home_radius_m", 0.1, 50.0, False, "Distance from home the charger reaches [m]"),
    ParamSpec("FS_GCS_ENABLE", "fs_gcs_enable", 0, 1, True, "1: hold position on GCS heartbeat loss"),
    ParamSpec("FS_GCS_TIMEOUT", "fs_gcs_timeout_s", 0.5, 120.0, False, "GCS heartbeat loss timeout [s]"),
    ParamSpec("SYSID_THISMAV", "sysid_thismav", 1, 255, True, "MAVLink system id (takes effect at restart)"),
)

FLOAT32_EPS = 1e-6  # relative; float32 keeps ~7 significant digits

BY_NAME: dict[str, ParamSpec] = {spec.name: spec for spec in PARAMS}
INDEX: dict[str, int] = {spec.name: i for i, spec in enumerate(PARAMS)}

assert all(len(spec.name) <= 16 for spec in PARAMS)
assert {spec.field for spec in PARAMS} == {f.name for f in fields(ApadParams)}


def _check(spec: ParamSpec, value: float) -> None:
    if not math.isfinite(value):
        raise ParamError(f"{spec.name}: {value} is not a number")
    if not spec.min_value <= value <= spec.max_value:
        raise ParamError(f"{spec.name}: {value:g} outside [{spec.min_value:g}, {spec.max_value:g}]")
    if spec.integral and value != int(value):
        raise ParamError(f"{spec.name}: {value:g} is not an integer")


def param_value(params: ApadParams, name: str) -> float:
    """The value of MAVLink parameter `name` as a float (C cast for integers, ArduPilot's way)."""
    spec = BY_NAME.get(name)
    if spec is None:
        raise ParamError(f"unknown parameter {name!r}")
    return float(getattr(params, spec.field))


def with_param(params: ApadParams, name: str, value: float) -> ApadParams:
    """`params` with `name` set to `value`, validated; raises ParamError and changes nothing if bad."""
    spec = BY_NAME.get(name)
    if spec is None:
        raise ParamError(f"unknown parameter {name!r}")
    value = float(value)
    # Values arrive as float32: a bound like 0.01 comes back as 0.0099999998. Snap, then check.
    for bound in (spec.min_value, spec.max_value):
        if math.isfinite(value) and abs(value - bound) <= FLOAT32_EPS * max(abs(bound), 1.0):
            value = float(bound)
    if spec.integral and math.isfinite(value) and abs(value - round(value)) <= FLOAT32_EPS * max(abs(value), 1.0):
        value = float(round(value))
    _check(spec, value)
    changes: dict[str, Any] = {spec.field: int(value) if spec.integral else value}
    return replace(params, **changes)
