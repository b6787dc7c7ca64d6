"""A resting aPad in closed form (apad_sitl.rest) against the stepped physics it stands for.

The pure part: from any start near a hold point, the stepped hull reaches a fixed point, and from
there the closed form after n steps equals n more steps of `vehicle.step` (the battery to float
rounding, everything else exactly). The wiring: a SITL aPad holding over real MAVLink rests, the
battery it reports keeps draining, and a command or a battery draw ends the rest.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from apad_sitl import primitives as prim
from apad_sitl.docking import MusselFixTable
from apad_sitl.endpoint import SitlVehicle
from apad_sitl.energy import EnergyMeter
from apad_sitl.hull_step import step_hull
from apad_sitl.params import ApadParams
from apad_sitl.rest import NEVER_STEPS, Rest, at_rest
from apad_sitl.state import ApadState
from apad_sitl.vehicle import BATTERY_EMPTY_V, BATTERY_FULL_V, VehicleState, step
from mavlink_dialect import Codec, mavlink, memory_pair
from missiontime import Scheduler, VirtualClock
from mussel_sim.geo import LocalFrame

DT = 0.1
STILL = (0.0, 0.0)
HOME = (43.94, 15.44)
HELD_FULL_STEPS = 8_000  # the longest the held-full test below steps a hull held full at home
MAX_SETTLE_STEPS = 20_000  # 2000 s: from a few metres off, the hold settles long before


def settle(state: VehicleState, target: tuple[float, float], params: ApadParams) -> VehicleState:
    """Step a hull holding at `target` until one step changes nothing but the battery."""
    hold = prim.hold(prim.PrimitiveState(), *target)
    for _ in range(MAX_SETTLE_STEPS):
        after = step(state, prim.velocity_setpoint(hold, state, params), params, STILL, DT)
        if at_rest(state, after):
            return after
        state = after
    raise AssertionError("the hold never came to rest")


def stepped(state: VehicleState, target: tuple[float, float], params: ApadParams, n: int) -> VehicleState:
    hold = prim.hold(prim.PrimitiveState(), *target)
    for _ in range(n):
        state = step(state, prim.velocity_setpoint(hold, state, params), params, STILL, DT)
    return state


offsets = st.floats(-6.0, 6.0, allow_nan=False)


@settings(max_examples=40, deadline=None)
@given(dx=offsets, dy=offsets, vx=st.floats(-0.5, 0.5), vy=st.floats(-0.5, 0.5),
       battery_v=st.floats(10.6, 16.0), n=st.integers(1, 3000),
       idle_vph=st.floats(0.0, 5.0), thrust_vph=st.floats(0.0, 50.0))
def test_the_closed_form_rest_equals_stepping(dx: float, dy: float, vx: float, vy: float, battery_v: float,
                                              n: int, idle_vph: float, thrust_vph: float) -> None:
    params = replace(ApadParams(), batt_drain_idle_vph=idle_vph, batt_drain_thrust_vph=thrust_vph)
    start = VehicleState(x_m=3.0 + dx, y_m=-2.0 + dy, vx_mps=vx, vy_mps=vy, water_vx_mps=vx, water_vy_mps=vy,
                         battery_v=battery_v)
    origin = settle(start, (3.0, -2.0), params)
    rest = Rest(origin, params, DT)
    rest.steps = n
    want = stepped(origin, (3.0, -2.0), params, n)
    got = rest.state()
    assert replace(got, battery_v=want.battery_v) == want  # all but the battery: exactly
    assert got.battery_v == pytest.approx(want.battery_v, abs=1e-9)


def test_a_rest_drains_to_empty_and_stays_there_as_stepping_does() -> None:
    params = ApadParams()
    origin = settle(VehicleState(x_m=1.0, battery_v=BATTERY_EMPTY_V + 0.01), (0.0, 0.0), params)
    rest = Rest(origin, params, DT)
    for n in (10, 700, 721, 722, 5000):  # 0.5 V/h: 0.01 V lasts 72 s, 720 steps
        rest.steps = n
        want = stepped(origin, (0.0, 0.0), params, n)
        assert rest.state().battery_v == pytest.approx(want.battery_v, abs=1e-12)
        assert rest.state().thrust_mps2 == want.thrust_mps2
    assert rest.state().battery_v == BATTERY_EMPTY_V


@settings(max_examples=200, deadline=None)
@given(battery_v=st.floats(BATTERY_EMPTY_V, 16.0), idle_vph=st.floats(0.0, 50.0), thrust=st.floats(0.0, 0.5))
def test_a_rest_changes_no_more_from_the_step_it_says(battery_v: float, idle_vph: float, thrust: float) -> None:
    """`still_from`, where the ideal link's streams stop looking ahead: `after` is the same from there on,
    and not two steps before (one: the thrust, 0 already, may drop to 0 a step after the battery went flat)."""
    params = replace(ApadParams(), batt_drain_idle_vph=idle_vph)
    rest = Rest(VehicleState(battery_v=battery_v, thrust_mps2=thrust), params, DT)
    n = rest.still_from()
    if n == NEVER_STEPS:  # a drain too small to empty it in any mission
        assert rest.after(n).battery_v > BATTERY_EMPTY_V
        return
    assert rest.after(n) == rest.after(n + 1) == rest.after(n + 10**9)
    if n > 0:
        assert rest.after(n).battery_v == BATTERY_EMPTY_V
    if n > 1:
        assert rest.after(n - 2) != rest.after(n)


def test_a_moving_hull_is_not_at_rest() -> None:
    params = ApadParams()
    moving = VehicleState(vx_mps=0.3, water_vx_mps=0.3)
    assert not at_rest(moving, step(moving, (0.3, 0.0), params, STILL, DT))
    drifting = VehicleState()
    assert not at_rest(drifting, step(drifting, (0.0, 0.0), params, (0.1, 0.0), DT))  # a current carries it


class Vehicle:
    """A SITL aPad on an in-memory pair and a virtual clock; a bare Codec plays the GCS."""

    def __init__(self) -> None:
        apad_end, self.gcs_end = memory_pair()
        self.clock = VirtualClock(Scheduler())
        self.vehicle = SitlVehicle(apad_end, ApadParams(fs_gcs_enable=0), *HOME)
        self.vehicle.state = VehicleState(x_m=10.0, y_m=10.0)  # away from the home charger (it would charge)
        self.vehicle.attach(self.clock.scheduler)
        self.gcs = Codec(250, 190)
        self.inbox: list[Any] = []

    def run(self, seconds: float) -> None:
        self.clock.sleep(seconds)
        for chunk in self.gcs_end.receive():
            self.inbox.extend(self.gcs.decode(chunk))

    def command(self, command: int, *params: float) -> None:
        p = [*params, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0][:7]
        self.gcs_end.send(self.gcs.encode(mavlink.MAVLink_command_long_message(1, 1, command, 0, *p)))

    def volts_mv(self) -> list[int]:
        return [m.voltage_battery for m in self.inbox if m.get_type() == "SYS_STATUS"]


def test_a_still_sitl_apad_rests_and_its_battery_still_drains_on_the_wire() -> None:
    v = Vehicle()
    v.run(60.0)
    apad = v.vehicle.apad
    assert apad.rest is not None, "still, away from home, in slack water: at rest"
    rest, counted, volts_before = apad.rest, apad.rest.steps, v.vehicle.state.battery_v
    v.run(3600.0)
    assert apad.rest is rest and rest.steps - counted == 36_000  # an hour of 10 Hz steps counted, none taken
    volts = v.volts_mv()
    assert volts[-1] < volts[0] - 400  # 0.5 V/h of hotel load, reported in SYS_STATUS
    assert v.vehicle.state.battery_v == pytest.approx(volts_before - 0.5, abs=1e-9)  # the hotel load's 0.5 V/h


def test_a_command_or_a_battery_draw_ends_the_rest() -> None:
    v = Vehicle()
    v.run(60.0)
    assert v.vehicle.apad.rest is not None
    v.vehicle.apad.state = replace(v.vehicle.state, battery_v=v.vehicle.state.battery_v - 0.1)  # a charging draw
    assert v.vehicle.apad.rest is None
    v.run(1.0)
    assert v.vehicle.apad.rest is not None  # the next step finds the fixed point again
    before = v.vehicle.state
    # A Go To 20 m north, as a stock GCS sends it: COMMAND_INT DO_REPOSITION in degE7.
    lat, lon = LocalFrame(*HOME).to_geodetic(before.x_m, before.y_m + 20.0)
    v.gcs_end.send(v.gcs.encode(mavlink.MAVLink_command_int_message(
        1, 1, mavlink.MAV_FRAME_GLOBAL_INT, mavlink.MAV_CMD_DO_REPOSITION, 0, 0, -1.0,
        mavlink.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, 0.0, math.nan, round(float(lat) * 1e7),
        round(float(lon) * 1e7), 0.0)))
    v.run(10.0)
    assert any(m.get_type() == "COMMAND_ACK" and m.result == mavlink.MAV_RESULT_ACCEPTED for m in v.inbox)
    assert v.vehicle.apad.rest is None and v.vehicle.state.y_m > before.y_m + 1.0


def _at_home(battery_v: float, charge_w: float) -> tuple[ApadState, EnergyMeter]:
    apad = ApadState(replace(ApadParams(), home_charge_w=charge_w))
    apad.state = VehicleState(x_m=0.5, y_m=-0.5, battery_v=battery_v)  # within the charger's 2 m, still
    return apad, EnergyMeter(apad)


@settings(max_examples=20, deadline=None)
@given(below_full_v=st.floats(0.0, 0.05), charge_w=st.floats(60.0, 400.0), n=st.integers(1, 8_000))
def test_a_hull_held_full_at_home_rests_and_counts_what_stepping_counts(below_full_v: float, charge_w: float,
                                                                          n: int) -> None:
    """At the home charger the hull charges (stepped) until the battery is held full, then rests: the
    battery, the charging flag, home charges and home Wh stay exactly what plain stepping makes."""
    rested, rested_meter = _at_home(BATTERY_FULL_V - below_full_v, charge_w)
    stepped_, stepped_meter = _at_home(BATTERY_FULL_V - below_full_v, charge_w)
    fixes = MusselFixTable(LocalFrame(*HOME))
    for _ in range(n):
        step_hull(rested, rested_meter, fixes, STILL, DT)
        before = stepped_.state
        stepped_.state = step(before, (0.0, 0.0), stepped_.params, STILL, DT)
        stepped_meter.step(DT)
    assert rested.state == stepped_.state
    assert rested.energy == stepped_.energy  # home Wh to the last bit, the charging flag, home charges
    params = rested.params
    charge_vph = params.home_charge_w / params.batt_capacity_wh * (BATTERY_FULL_V - BATTERY_EMPTY_V)
    net_vph = charge_vph - params.batt_drain_idle_vph
    if n > 3600 / DT * below_full_v / net_vph + 10:  # charged up, and a step more
        assert rested.rest is not None and rested.rest.refill_wh is not None, "held full at home: at rest"


@settings(max_examples=10, deadline=None)
@given(below_full_v=st.floats(0.5, 2.0), charge_w=st.floats(100.0, 400.0))
def test_a_hull_charging_at_home_rests_charging_and_makes_what_stepping_makes_until_full(below_full_v: float,
                                                                                       charge_w: float) -> None:
    """Below full at the charger the battery alone changes: a charging rest takes the steps (`ChargingRest`),
    to the same floats as stepping, and once full the hull rests held full."""
    rested, rested_meter = _at_home(BATTERY_FULL_V - below_full_v, charge_w)
    stepped_, stepped_meter = _at_home(BATTERY_FULL_V - below_full_v, charge_w)
    fixes = MusselFixTable(LocalFrame(*HOME))
    kinds = []
    full_at: int | None = None
    for k in range(round(3600 / DT * 2.0 * below_full_v / (charge_w / 400.0 * 5.5 - 0.5)) + 50):  # to full, twice over
        step_hull(rested, rested_meter, fixes, STILL, DT)
        stepped_.state = step(stepped_.state, (0.0, 0.0), stepped_.params, STILL, DT)
        stepped_meter.step(DT)
        assert rested.state == stepped_.state and rested.energy == stepped_.energy
        kinds.append(type(rested.rest).__name__)
        full_at = k if full_at is None and rested.state.battery_v == BATTERY_FULL_V else full_at
        if full_at is not None and k - full_at == HELD_FULL_STEPS:
            break  # held full as long as the test above holds it at most: more is that test's
    assert "ChargingRest" in kinds and kinds[-1] == "Rest" and rested.rest is not None and rested.rest.refill_wh
    assert rested.state.battery_v == BATTERY_FULL_V and rested.energy.home_charges == 1
