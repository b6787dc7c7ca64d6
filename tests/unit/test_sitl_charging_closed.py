"""A charging rest in closed form (the ideal link's, `ChargingRest(closed=True)`): the battery and the home
energy it takes over any split of the steps are what stepping makes to float rounding, it comes to full
at the step stepping does (or one off, the rounding of a product for a sum), and its foresight (`after`,
`still_from`, what the streams plan their reports by) says where the battery is and when it is full."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from apad_sitl.energy_counters import EnergyCounters
from apad_sitl.params import ApadParams
from apad_sitl.rest import ChargingRest
from apad_sitl.vehicle import BATTERY_FULL_V, VehicleState

DT = 0.1


def charge(rest: ChargingRest, chunks: list[int]) -> tuple[list[float], EnergyCounters, int]:
    """The battery after each chunk of steps, the counters, and the step at which the battery came to full."""
    counters, seen, full_at = EnergyCounters(), [], -1
    for n in chunks:
        taken = rest.take(n, counters)
        seen.append(rest.battery_v)
        if taken < n and full_at < 0:
            full_at = rest.steps
    return seen, counters, full_at


@settings(max_examples=25, deadline=None)
@given(below_full_v=st.floats(0.01, 4.0), charge_w=st.floats(60.0, 400.0),
       chunks=st.lists(st.integers(1, 5_000), min_size=1, max_size=40))
def test_a_closed_charging_rest_is_stepping_to_float_rounding(below_full_v: float, charge_w: float,
                                                              chunks: list[int]) -> None:
    params = ApadParams(home_charge_w=charge_w)
    origin = VehicleState(battery_v=BATTERY_FULL_V - below_full_v)
    chunks = [*chunks, 10**6]  # and on to full
    closed, stepped = ChargingRest(origin, params, DT, closed=True), ChargingRest(origin, params, DT)
    foresight = closed.after(10**5), closed.still_from()
    a, a_counters, a_full = charge(closed, chunks)
    b, b_counters, b_full = charge(stepped, chunks)
    assert a == pytest.approx(b, rel=0.0, abs=1e-9)
    assert a_counters.home_wh == pytest.approx(b_counters.home_wh, rel=1e-9)
    assert a[-1] == b[-1] == BATTERY_FULL_V and abs(a_full - b_full) <= 1
    assert foresight[1] >= b_full >= foresight[1] - 4  # full from then on, told a few steps after at most
    if foresight[1] <= 10**5:
        assert foresight[0].battery_v == BATTERY_FULL_V


def test_its_foresight_is_the_battery_stepping_leaves_before_full() -> None:
    params = ApadParams(home_charge_w=200.0)
    origin = VehicleState(battery_v=12.0)
    closed, stepped = ChargingRest(origin, params, DT, closed=True), ChargingRest(origin, params, DT)
    counters = EnergyCounters()
    for n in (1, 10, 500, 20_000):
        ahead = closed.after(n).battery_v
        stepped.take(n - stepped.steps, counters)
        assert ahead == pytest.approx(stepped.battery_v, rel=0.0, abs=1e-9) and ahead < BATTERY_FULL_V
