"""The GCS's foresight of a simulated aMussel between its reports (`gcs.belief.foresight`), against the
fleet's own model stepped the same seconds: what a report every step would have said."""

from __future__ import annotations

import numpy as np
import pytest

from gcs.belief.foresight import MODEL_STEP_US, charged_forward, foreseen_battery, foreseen_deployed, steps_since
from gcs.link.telemetry import MusselView
from mussel_sim.battery import DISCHARGE_ACTIVE_PER_MIN, charge_profile, discharge_profile, sim_minutes, step_battery
from mussel_sim.vocabulary import MusselState

THETA = 30.0
CHARGE = charge_profile("secondary")
DISCHARGE = discharge_profile("active")
DRAIN_PER_S = DISCHARGE_ACTIVE_PER_MIN * sim_minutes(THETA, 1.0)


def view(state: MusselState, battery: float, time_us: int = 0) -> MusselView:
    return MusselView(7, 0, 0, 0.0, battery, 4000, state, True, time_us)


def stepped(battery: float, docked: list[bool]) -> float:
    """The fleet's eqs. (1)-(2), one 1 s step per entry (docked: charging)."""
    u = np.array([battery])
    for d in docked:
        u = step_battery(u, np.array([d]), DISCHARGE, CHARGE, THETA, 1.0)
    return float(u[0])


def test_whole_steps_only_a_report_within_its_step_stands() -> None:
    assert steps_since(5 * MODEL_STEP_US, 5 * MODEL_STEP_US + 999_999) == 0
    assert steps_since(5 * MODEL_STEP_US, 8 * MODEL_STEP_US + 500_000) == 3
    assert steps_since(9 * MODEL_STEP_US, 8 * MODEL_STEP_US) == 0  # a report from the future: none
    assert foreseen_battery(view(MusselState.ACTIVE, 0.6), 999_999, DRAIN_PER_S, CHARGE, THETA) == 0.6


@pytest.mark.parametrize("state", [MusselState.ACTIVE, MusselState.SURFACING, MusselState.SINKING,
                                   MusselState.FLOATING])
def test_a_deployed_one_drains_as_the_fleet_steps_it(state: MusselState) -> None:
    got = foreseen_battery(view(state, 0.6), 4 * MODEL_STEP_US + 300_000, DRAIN_PER_S, CHARGE, THETA)
    assert got == pytest.approx(stepped(0.6, [False] * 4), abs=1e-15)
    assert foreseen_battery(view(state, 0.001), 10 * MODEL_STEP_US, DRAIN_PER_S, CHARGE, THETA) == 0.0


@pytest.mark.parametrize("battery", [0.1, 0.1619, 0.5632, 0.97, 0.9995])
def test_a_docked_one_charges_by_the_bands_as_the_fleet_steps_it(battery: float) -> None:
    # Across a band's edge (0.16197, 0.5634) the rate is chosen from the value before each step; full stays full.
    got = foreseen_battery(view(MusselState.DOCKED, battery), 5 * MODEL_STEP_US, DRAIN_PER_S, CHARGE, THETA)
    assert got == pytest.approx(stepped(battery, [True] * 5), abs=1e-15)
    assert charged_forward(1.0, 5, CHARGE, THETA) == 1.0


def test_a_released_one_charged_till_the_release_and_drains_after() -> None:
    # Reported docked at 10 s, let go at 12.4 s: charged in the steps at 11 and 12, drained at 13 .. 16.
    released_us = 12 * MODEL_STEP_US + 400_000
    got = foreseen_battery(view(MusselState.DOCKED, 0.7, 10 * MODEL_STEP_US), 16 * MODEL_STEP_US + 200_000,
                           DRAIN_PER_S, CHARGE, THETA, released_us=released_us)
    assert got == pytest.approx(stepped(0.7, [True] * 2 + [False] * 4), abs=1e-15)
    # Released at its report: drained all the way.
    got = foreseen_battery(view(MusselState.DOCKED, 0.7, 10 * MODEL_STEP_US), 16 * MODEL_STEP_US,
                           DRAIN_PER_S, CHARGE, THETA, released_us=10 * MODEL_STEP_US)
    assert got == pytest.approx(stepped(0.7, [False] * 6), abs=1e-15)


def test_a_depleted_one_stays_as_reported() -> None:
    assert foreseen_battery(view(MusselState.DEPLETED, 0.0), 60 * MODEL_STEP_US, DRAIN_PER_S, CHARGE, THETA) == 0.0


def test_a_tables_deployed_ones_at_once_are_each_one_foreseen_to_the_bit() -> None:
    """`foreseen_deployed` (the pool's beliefs in one array operation) against `foreseen_battery` row by row."""
    rng = np.random.default_rng(3)
    battery = rng.uniform(0.0, 1.0, 200)
    report_us = rng.integers(0, 40 * MODEL_STEP_US, 200)
    drain = rng.uniform(0.0, 2 * DRAIN_PER_S, 200)
    now_us = 30 * MODEL_STEP_US + 250_000  # some reports are from after now: as reported
    at_once = foreseen_deployed(battery, report_us, now_us, drain)
    one_by_one = [foreseen_battery(view(MusselState.ACTIVE, float(b), int(t)), now_us, float(d), CHARGE, THETA)
                  for b, t, d in zip(battery, report_us, drain, strict=True)]
    assert at_once.tolist() == one_by_one
    assert (at_once < battery).any() and (at_once == battery).any()  # run down, and reports from after now


@pytest.mark.parametrize("battery", [0.0, 0.05, 0.1619, 0.3, 0.5633, 0.8])
@pytest.mark.parametrize("steps", [65, 200, 1_000, 20_000])
def test_a_long_stretch_in_closed_form_is_the_fleet_s_steps_to_float_noise(battery: float, steps: int) -> None:
    """The event platform's reports are far apart: a docked one charged over thousands of steps at once,
    band by band, ends where the fleet's own steps end (across both band edges and at full)."""
    assert charged_forward(battery, steps, CHARGE, THETA) == pytest.approx(stepped(battery, [True] * steps),
                                                                          abs=1e-12)


def test_a_long_stretch_costs_a_few_operations_not_one_per_step() -> None:
    calls = []

    class Counting(list[float]):
        def __getitem__(self, i):  # type: ignore[no-untyped-def, override]
            calls.append(i)
            return super().__getitem__(i)

    counting = type(CHARGE)(CHARGE.name, CHARGE.thresholds, tuple(CHARGE.rates_per_min))
    object.__setattr__(counting, "rates_per_min", Counting(CHARGE.rates_per_min))
    charged_forward(0.0, 50_000, counting, THETA)
    assert len(calls) < 3 * 2 * 64  # per band: its closed form and the steps near its edge


@pytest.mark.parametrize("last_spoke_s", [100, 583, 631])
def test_after_a_sleep_order_the_belief_does_not_depend_on_when_the_amussel_last_spoke(last_spoke_s: int) -> None:
    """A sleeper speaks only at its wakes; lockstep's and the event platform's GCS hear it at different ones.
    An order at 637.05 s changes its drain from the fleet's next step (638 s): the belief runs the old duty to
    the order (the anchor) and the new one after it, so every last report gives the truth (bay-capacity
    keep_alive seed 2 planned on 0.788 against a true 0.811 when it had last heard the sleeper at 583 s)."""
    old, new, battery = DRAIN_PER_S / 20, DRAIN_PER_S, 0.83
    order_us, now_us = 637_050_000, 700 * MODEL_STEP_US
    truth = battery - 637 * old - (700 - 637) * new  # old duty up to the step at 637 s, the new one from 638 s
    heard = view(MusselState.ACTIVE, battery - last_spoke_s * old, last_spoke_s * MODEL_STEP_US)
    anchor = (order_us, foreseen_battery(heard, order_us, old, CHARGE, THETA))
    assert foreseen_battery(heard, now_us, new, CHARGE, THETA, None, anchor) == pytest.approx(truth, abs=1e-12)
    assert foreseen_battery(heard, 637_900_000, new, CHARGE, THETA, None, anchor) == anchor[1]  # no step yet
    later = view(MusselState.ACTIVE, 0.5, 650 * MODEL_STEP_US)  # a report after the order: the report counts
    assert foreseen_battery(later, now_us, new, CHARGE, THETA, None, anchor) == pytest.approx(0.5 - 50 * new)
