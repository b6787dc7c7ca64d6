"""A busy hull stepped ahead (`apad_sitl.track`) against the tick's own stepping, to the bit.

Where no equation holds (a Go To's turn and acceleration, its sqrt-law approach, the braking after its
victory radius, an Undock drifting off while its latch opens), the ideal link steps the hull ahead in
one call. Each of its steps must be the tick's step exactly (the same functions on the same floats),
and it must stop before the first step a tick would have to take itself: the primitive changing other
than its timers, the hull coming to rest, the home charger able to act.
"""

from __future__ import annotations

import math
from dataclasses import replace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from apad_sitl import primitives as prim
from apad_sitl import track
from apad_sitl import vehicle as veh
from apad_sitl.home_charger import HOME_STILL_MPS
from apad_sitl.latch_hold import closing_fixes, timers_only
from apad_sitl.params import ApadParams
from apad_sitl.primitives import MusselFix, PrimitiveState
from apad_sitl.rest import at_rest
from apad_sitl.vehicle import VehicleState

DT_S = 0.1
coordinate = st.floats(-40.0, 40.0)
velocity = st.floats(-0.6, 0.6)


def _stepped(state: VehicleState, primitive: PrimitiveState, params: ApadParams, current: tuple[float, float],
             fixes: dict[int, MusselFix]) -> tuple[VehicleState, PrimitiveState]:
    """One tick of `hull_step.step_hull` for an armed, busy hull away from home."""
    after = veh.step(state, prim.velocity_setpoint(primitive, state, params), params, current, DT_S)
    return after, prim.step(primitive, after.x_m, after.y_m, fixes, params, DT_S)


@settings(max_examples=60, deadline=None)
@given(x=coordinate, y=coordinate, tx=coordinate, ty=coordinate, vx=velocity, vy=velocity,
       heading=st.floats(0.0, 6.28), kind=st.sampled_from(["goto", "dock", "undock"]),
       current=st.sampled_from([(0.0, 0.0), (0.05, -0.03)]), home_w=st.sampled_from([0.0, 100.0]))
def test_a_track_is_the_ticks_own_stepping_and_stops_where_a_tick_must_act(
        x: float, y: float, tx: float, ty: float, vx: float, vy: float, heading: float, kind: str,
        current: tuple[float, float], home_w: float) -> None:
    params = ApadParams(home_charge_w=home_w)
    origin = VehicleState(x_m=x, y_m=y, vx_mps=vx + current[0], vy_mps=vy + current[1], water_vx_mps=vx,
                          water_vy_mps=vy, heading_rad=heading, battery_v=14.0, distance_travelled_m=5.0)
    fixes = {7: MusselFix(x + 0.3, y - 0.2)}
    primitive = prim.go_to(PrimitiveState(), tx, ty)
    if kind != "goto":
        primitive, refused = prim.dock(replace(primitive, progress=prim.Progress.DONE), 2, 7, x, y, fixes, params)
        assert refused is None
    if kind == "undock":
        docked = primitive
        while docked.progress == prim.Progress.IN_PROGRESS:
            docked = prim.step(docked, x, y, fixes, params, DT_S)
        primitive, refused = prim.undock(docked, 2, 7, x, y, params)
        assert refused is None
    found = track.found(origin, primitive, params, current, fixes, closing_fixes(primitive, fixes), DT_S)
    state, stepped = origin, primitive
    steps = 0 if found is None else found.limit
    for n in range(1, steps + 1):
        assert found is not None
        state, stepped = _stepped(state, stepped, params, current, fixes)
        found.steps = n
        assert found.state() == state and found.primitive() == stepped, n  # to the bit
    # Where it stopped (or why none was found): the next tick changes the primitive beyond its timers,
    # comes to rest, could charge at home, or the track ran its length.
    none_worth_it = found is None and _short(origin, primitive, params, current, fixes)
    assert _tick_acts(state, stepped, params, current, fixes) or steps == track.MAX_STEPS or none_worth_it


def _tick_acts(state: VehicleState, primitive: PrimitiveState, params: ApadParams, current: tuple[float, float],
               fixes: dict[int, MusselFix]) -> bool:
    """Whether the next tick from here does what a track cannot hold: changes the primitive beyond its timers,
    comes to rest, or could charge at home (the rule written out again here, not read from `track`)."""
    after, new = _stepped(state, primitive, params, current, fixes)
    home = params.home_charge_w > 0.0 and math.hypot(after.x_m, after.y_m) <= params.home_radius_m \
        and after.ground_speed_mps < HOME_STILL_MPS
    return (new is not primitive and not timers_only(primitive, new)) or at_rest(state, after) or home


def _short(origin: VehicleState, primitive: PrimitiveState, params: ApadParams, current: tuple[float, float],
           fixes: dict[int, MusselFix]) -> bool:
    """None found: a tick acts within `track.MIN_STEPS` steps."""
    state, stepped = origin, primitive
    for _ in range(track.MIN_STEPS):
        if _tick_acts(state, stepped, params, current, fixes):
            return True
        state, stepped = _stepped(state, stepped, params, current, fixes)
    return False


def test_a_go_to_from_rest_is_one_track_after_another_to_its_victory_radius() -> None:
    """A Go To of 30 m from rest: accelerating, cruising, braking, each a track of up to MAX_STEPS; the last
    stops on the step before the one that reaches the radius (that one is the tick's: it says DONE)."""
    params = ApadParams()
    state = VehicleState(x_m=10.0, y_m=-20.0, battery_v=15.0)  # away from the home charger
    primitive = prim.go_to(PrimitiveState(), 28.0, 4.0)
    tracks = 0
    while True:
        found = track.found(state, primitive, params, (0.0, 0.0), {}, (), DT_S)
        if found is None:
            break
        tracks += 1
        found.steps = found.limit
        state, primitive = found.state(), found.primitive()
        if found.limit < track.MAX_STEPS:
            break
    assert tracks >= 2  # 30 m at 0.5 m/s: a minute, several tracks
    after, done = _stepped(state, primitive, params, (0.0, 0.0), {})
    assert primitive.progress == prim.Progress.IN_PROGRESS and done.progress == prim.Progress.DONE
    assert math.hypot(28.0 - after.x_m, 4.0 - after.y_m) <= params.wp_radius_m


def test_after_its_radius_the_hull_is_tracked_until_the_tick_that_finds_it_at_rest() -> None:
    """Braking and settling onto the point reached: tracks up to the step before the hull's fixed point, so
    that the tick that finds it makes the rest (`rest.Rest`: a resting hull costs nothing per step)."""
    params = ApadParams()
    state = VehicleState(x_m=27.9, y_m=3.9, vx_mps=0.2, vy_mps=0.1, water_vx_mps=0.2, water_vy_mps=0.1, battery_v=15.0)
    primitive = replace(prim.go_to(PrimitiveState(), 28.0, 4.0), progress=prim.Progress.DONE)
    for _ in range(10_000):
        found = track.found(state, primitive, params, (0.0, 0.0), {}, (), DT_S)
        assert found is not None  # settling: every step moves the hull until it stops
        found.steps = found.limit
        state = found.state()
        if found.limit < track.MAX_STEPS:
            break
    else:
        pytest.fail("the hull never came to rest")
    assert not at_rest(found.after(found.limit - 1), state)  # the first fixed point, not one after it
    after, same = _stepped(state, primitive, params, (0.0, 0.0), {})
    assert at_rest(state, after) and same is primitive
    assert (state.x_m, state.y_m) == (after.x_m, after.y_m)
