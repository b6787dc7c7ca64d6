"""The aPad kinematic model: bounds, current, heading, battery. Analytic cases, no I/O."""

from __future__ import annotations

import math
from itertools import pairwise

import pytest

from apad_sitl.params import ApadParams
from apad_sitl.vehicle import BATTERY_EMPTY_V, BATTERY_FULL_V, VehicleState, step

P = ApadParams()
DT = 0.1
STILL = (0.0, 0.0)


def run(state: VehicleState, setpoint: tuple[float, float], seconds: float,
        current: tuple[float, float] = STILL, params: ApadParams = P) -> list[VehicleState]:
    states = [state]
    for _ in range(round(seconds / DT)):
        states.append(step(states[-1], setpoint, params, current, DT))
    return states


def test_speed_is_bounded_by_speed_max() -> None:
    states = run(VehicleState(), (3.0, 4.0), 30.0)
    assert max(s.ground_speed_mps for s in states) == pytest.approx(P.speed_max_mps)
    last = states[-1]
    # Direction of the setpoint is kept when its magnitude is clipped.
    assert last.vx_mps / last.vy_mps == pytest.approx(3.0 / 4.0)


def test_acceleration_is_bounded_and_takes_speed_over_accel_to_reach_full_speed() -> None:
    states = run(VehicleState(), (1.0, 0.0), 5.0)
    dv = [abs(b.water_vx_mps - a.water_vx_mps) for a, b in pairwise(states)]
    assert max(dv) <= P.accel_max_mps2 * DT + 1e-12
    t_full = next(i for i, s in enumerate(states) if s.vx_mps >= P.speed_max_mps - 1e-9) * DT
    assert t_full == pytest.approx(P.speed_max_mps / P.accel_max_mps2, abs=DT)


def test_braking_is_bounded_too() -> None:
    moving = VehicleState(water_vx_mps=0.5, vx_mps=0.5)
    states = run(moving, (0.0, 0.0), 1.0)
    assert states[-1].vx_mps == pytest.approx(0.5 - P.accel_max_mps2 * 1.0)


def test_current_carries_an_uncontrolled_hull() -> None:
    current = (0.2, -0.1)
    states = run(VehicleState(), STILL, 100.0, current)
    last = states[-1]
    assert (last.x_m, last.y_m) == (pytest.approx(20.0), pytest.approx(-10.0))
    assert (last.vx_mps, last.vy_mps) == (pytest.approx(0.2), pytest.approx(-0.1))
    assert (last.water_vx_mps, last.water_vy_mps) == (0.0, 0.0)
    # Drifting is travelling: the distance counts ground speed.
    assert last.distance_travelled_m == pytest.approx(100.0 * math.hypot(*current))


def test_thrust_against_the_current_keeps_the_hull_still() -> None:
    states = run(VehicleState(water_vx_mps=-0.2), (-0.2, 0.0), 60.0, (0.2, 0.0))
    assert states[-1].x_m == pytest.approx(0.0, abs=1e-9)
    assert states[-1].distance_travelled_m == pytest.approx(0.0, abs=1e-9)


def drained_v(setpoint: tuple[float, float], seconds: float = 600.0, current: tuple[float, float] = STILL) -> float:
    return BATTERY_FULL_V - run(VehicleState(), setpoint, seconds, current)[-1].battery_v


def test_idle_drain_is_the_hotel_load() -> None:
    assert drained_v(STILL, 3600.0) == pytest.approx(P.batt_drain_idle_vph)


def test_battery_drains_faster_with_more_thrust() -> None:
    idle = drained_v(STILL)
    slow = drained_v((0.2, 0.0))
    fast = drained_v((0.5, 0.0))
    fighting_current = drained_v((-0.5, 0.0), current=(0.5, 0.0))
    assert idle < slow < fast
    assert fighting_current == pytest.approx(fast, rel=1e-3)  # thrust is water-relative
    # Cruise at 0.5 m/s: thrust = THR_DRAG * v, so drain = idle + k (drag v)^2 per hour.
    expected_vph = P.batt_drain_idle_vph + P.batt_drain_thrust_vph * (P.drag_per_s * 0.5) ** 2
    assert fast == pytest.approx(expected_vph / 6.0, rel=0.02)  # 600 s, minus the 2 s speed-up


def test_battery_stops_at_empty_and_thrusters_stop_with_it() -> None:
    flat = VehicleState(battery_v=BATTERY_EMPTY_V, water_vx_mps=0.5, vx_mps=0.5)
    states = run(flat, (0.5, 0.0), 10.0)
    assert all(s.battery_v == BATTERY_EMPTY_V for s in states)
    assert states[-1].vx_mps == 0.0
    assert states[-1].thrust_mps2 == 0.0


def test_heading_turns_toward_travel_at_a_bounded_rate() -> None:
    states = run(VehicleState(heading_rad=0.0), (-0.5, 0.0), 20.0)  # west, from facing north
    rate_max = math.radians(P.yaw_rate_max_dps)
    for a, b in pairwise(states):
        turn = (b.heading_rad - a.heading_rad + math.pi) % (2 * math.pi) - math.pi
        assert abs(turn) <= rate_max * DT + 1e-12
        assert b.yaw_rate_radps == pytest.approx(turn / DT)
    assert states[-1].heading_rad == pytest.approx(1.5 * math.pi)
    # The short way round: north -> west turns anticlockwise, through 350 deg not 10 deg.
    assert states[5].heading_rad > math.pi


def test_heading_holds_when_stopped() -> None:
    states = run(VehicleState(heading_rad=1.0), STILL, 10.0, current=(0.3, 0.0))
    assert all(s.heading_rad == 1.0 for s in states)


def test_step_is_pure_and_zero_dt_changes_nothing() -> None:
    start = VehicleState(x_m=1.0, water_vx_mps=0.1, vx_mps=0.1)
    assert step(start, (0.5, 0.5), P, (0.1, 0.1), 0.0) is start
    after = step(start, (0.5, 0.5), P, (0.1, 0.1), 1.0)
    assert start == VehicleState(x_m=1.0, water_vx_mps=0.1, vx_mps=0.1)
    assert after == step(start, (0.5, 0.5), P, (0.1, 0.1), 1.0)
