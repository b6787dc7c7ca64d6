"""The aPad's energy (issue 20): the SITL's meter (aMussels' gains drawn from the battery through
the inductive link; the home charger) and the GCS's budget (a trip it cannot finish is not started)."""

from __future__ import annotations

from dataclasses import replace

import pytest

from apad_sitl.energy import EnergyMeter
from apad_sitl.params import ApadParams
from apad_sitl.primitives import PrimitiveState, SlotState
from apad_sitl.state import ApadState
from apad_sitl.vehicle import BATTERY_EMPTY_V, BATTERY_FULL_V
from apad_sitl.vocabulary import Latch
from gcs.belief.energy_budget import EnergyBudget

RANGE_V = BATTERY_FULL_V - BATTERY_EMPTY_V


def _apad(**params: float) -> ApadState:
    apad = ApadState(replace(ApadParams(), **params))
    slots = (SlotState(mussel_id=7, latch=Latch.LATCHED), SlotState(mussel_id=9, latch=Latch.CLOSING),
             SlotState(), SlotState())
    apad.set_primitive(replace(PrimitiveState(), slots=slots))
    return apad


def test_a_latched_amussels_gain_is_drawn_from_the_apads_battery_at_the_links_efficiency() -> None:
    apad = _apad(batt_capacity_wh=400.0, mussel_battery_wh=24.0, charge_efficiency=0.6)  # round numbers
    meter = EnergyMeter(apad)
    meter.heard([(7, 0.50, 100), (9, 0.30, 100), (3, 0.10, 100)])  # 9 is not latched yet, 3 is not aboard
    meter.heard([(7, 0.75, 100), (9, 0.60, 100), (3, 0.90, 100)])
    meter.heard([(7, 0.0, 66), (7, 1.0, 66)])  # a stranger's claims of aMussel 7: not believed
    assert apad.energy.passed_wh == pytest.approx(0.25 * 24.0)
    assert apad.energy.drawn_wh == pytest.approx(0.25 * 24.0 / 0.6)
    assert apad.state.battery_v == pytest.approx(BATTERY_FULL_V - 10.0 / 400.0 * RANGE_V)
    meter.heard([(7, 0.70, 100)])  # a report lower than the last: nothing drawn, nothing given back
    assert apad.energy.drawn_wh == pytest.approx(10.0)
    meter.heard([(7, 0.75, 100)])  # back up to its high of 0.75, not above: nothing drawn twice
    assert apad.energy.drawn_wh == pytest.approx(10.0)
    meter.heard([(7, 0.85, 100)])  # above it: the new high's 0.10 only
    assert apad.energy.passed_wh == pytest.approx(0.35 * 24.0)


def test_a_hostile_run_of_reports_passes_at_most_one_battery_a_latch() -> None:
    """A stranger that reports a latched aMussel first, then swings it between empty and full fifty
    times, passes one battery (7.4 Wh), not fifty: the aPad's battery stays near full."""
    apad = _apad(batt_capacity_wh=400.0, mussel_battery_wh=7.4, charge_efficiency=0.6)
    meter = EnergyMeter(apad)
    for k in range(100):
        meter.heard([(7, float(k % 2), 66)])
    assert apad.energy.passed_wh == pytest.approx(7.4)
    assert apad.state.battery_v == pytest.approx(BATTERY_FULL_V - 7.4 / 0.6 / 400.0 * RANGE_V)


def test_a_battery_out_of_its_range_is_counted_and_passes_nothing() -> None:
    apad = _apad(batt_capacity_wh=400.0, mussel_battery_wh=7.4)
    meter = EnergyMeter(apad)
    meter.heard([(7, 0.2, 100), (7, 1e9, 100), (7, float("nan"), 100), (7, -0.5, 100), (3, 5.0, 100)])
    assert apad.energy.passed_wh == 0.0 and apad.state.battery_v == BATTERY_FULL_V
    assert meter.dropped == {"invalid:AMUSSEL_STATUS:battery": 3}  # 3 is not aboard: not the meter's to judge


def test_at_home_and_still_the_charger_fills_the_battery_and_stops_when_full() -> None:
    apad = _apad(batt_capacity_wh=100.0, home_charge_w=100.0, home_radius_m=2.0)
    apad.state = replace(apad.state, battery_v=BATTERY_EMPTY_V + RANGE_V / 2, x_m=1.0)
    meter = EnergyMeter(apad)
    meter.step(1800.0)  # half an hour at 100 W: 50 Wh, the half that was missing
    assert apad.energy.charging and apad.energy.home_charges == 1
    assert apad.state.battery_v == pytest.approx(BATTERY_FULL_V) and apad.energy.home_wh == pytest.approx(50.0)
    meter.step(60.0)
    assert not apad.energy.charging and apad.energy.home_wh == pytest.approx(50.0)
    away = _apad(batt_capacity_wh=100.0, home_charge_w=100.0)
    away.state = replace(away.state, battery_v=12.0, x_m=5.0)  # beyond the charger's reach
    EnergyMeter(away).step(600.0)
    assert away.state.battery_v == 12.0 and not away.energy.charging


def test_the_budget_refuses_a_trip_that_would_eat_into_the_reserve() -> None:
    budget = EnergyBudget.of(replace(ApadParams(), batt_capacity_wh=400.0), speed_mps=0.5)
    assert budget.hotel_w == pytest.approx(0.5 / RANGE_V * 400.0)  # 0.5 V/h of 5.5 V of 400 Wh: 36 W
    half = BATTERY_EMPTY_V + RANGE_V / 2  # 200 Wh left, 60 Wh reserve: 140 Wh to spend
    four_charges = budget.trip_wh(0.0, 0.0, charge_frac=4 * 0.8)  # 3.2 x 7.4 Wh / 0.6 = 39.5 Wh
    assert four_charges == pytest.approx(3.2 * 7.4 / 0.6)
    assert budget.affords(half, four_charges)
    assert not budget.affords(half, budget.trip_wh(200.0, 3 * 3600.0, charge_frac=4 * 0.8))  # + 108 Wh hotel
    assert budget.charged(BATTERY_FULL_V) and not budget.charged(half)
