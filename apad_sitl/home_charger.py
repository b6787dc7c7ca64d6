"""The home charging station's arithmetic for one physics step (pure; `apad_sitl.energy` meters it).

The jack charges the battery at `home_charge_w` until full, the battery linear in voltage over
VOLT_RANGE. One place for the step, so that the meter's step and a resting hull's steps at the
charger (`apad_sitl.rest.ChargingRest`) make the same floats.
"""

from __future__ import annotations

import math

from apad_sitl.params import ApadParams
from apad_sitl.vehicle import BATTERY_EMPTY_V, BATTERY_FULL_V, VOLT_RANGE, VehicleState

HOME_STILL_MPS = 0.05  # slower than this over ground: the hull can be plugged in


def could_charge(state: VehicleState, params: ApadParams) -> bool:
    """A charger at home, the hull within its reach and slow enough to be plugged in: a step would charge a
    battery below full (`energy.EnergyMeter`, and a busy hull's track ahead, `track`)."""
    return (params.home_charge_w > 0.0 and math.hypot(state.x_m, state.y_m) <= params.home_radius_m
            and state.ground_speed_mps < HOME_STILL_MPS)


def home_charge_wh(battery_v: float, params: ApadParams, dt_s: float) -> float:
    """Wh the charger puts in over `dt_s` from `battery_v` (below full): its power, or what is left to full."""
    to_full_wh = (BATTERY_FULL_V - battery_v) / VOLT_RANGE * params.batt_capacity_wh
    return min(params.home_charge_w * dt_s / 3600.0, to_full_wh)


def volts_after(battery_v: float, wh: float, params: ApadParams) -> float:
    """The battery after `wh` more (fewer, if negative), within its range."""
    return min(BATTERY_FULL_V, max(BATTERY_EMPTY_V, battery_v + wh / params.batt_capacity_wh * VOLT_RANGE))
