"""Battery model against the paper's closed forms (eqs. (1)-(2), Table I)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from mussel_sim.battery import (
    CHARGE_PROFILES,
    DISCHARGE_PROFILES,
    charge_profile,
    discharge_profile,
    from_millivolts,
    step_battery,
    to_millivolts,
)

ACTIVE_RATE = 0.0010427134  # eq. (1)
BANDS = (0.16197, 0.5634)  # eq. (2)
RATES = (0.001045, 0.00223, 0.002911)

ACT = DISCHARGE_PROFILES["active"]
SEC = CHARGE_PROFILES["secondary"]


def one(u: float, charging: bool, theta: float = 30.0, dt_s: float = 1.0) -> float:
    return float(step_battery(np.array([u]), np.array([charging]), ACT, SEC, theta, dt_s)[0])


def test_defaults_are_the_paper_equations() -> None:
    assert ACT.rate_per_min == ACTIVE_RATE
    assert SEC.thresholds == BANDS
    assert SEC.rates_per_min == RATES


def test_one_1hz_step_with_theta_30_discharges_the_closed_form() -> None:
    expected = ACTIVE_RATE * 30 / 60  # 0.0005213567
    assert abs((0.8 - one(0.8, False)) - expected) < 1e-12
    assert abs((0.8 - one(0.8, False)) - 0.000521357) < 1e-9  # the value quoted to 9 decimals


def test_active_from_full_depletes_after_959_simulated_minutes() -> None:
    # theta = 1 and 60 s steps: one step is one simulated minute.
    t_empty_min = 1 / ACTIVE_RATE  # 959.036...
    u = np.ones(1)
    steps = 0
    while u[0] > 0:
        u = step_battery(u, np.zeros(1, bool), ACT, SEC, 1.0, 60.0)
        steps += 1
    assert steps == math.ceil(t_empty_min) == 960
    assert u[0] == 0.0  # clamped, not negative


def charge_time_min() -> float:
    """Eq. (2) integrated from 0 to 1: each band's width over its rate."""
    return BANDS[0] / RATES[0] + (BANDS[1] - BANDS[0]) / RATES[1] + (1 - BANDS[1]) / RATES[2]


def test_docked_from_empty_is_full_after_about_485_simulated_minutes() -> None:
    t_full_min = charge_time_min()
    assert t_full_min == pytest.approx(485.0, abs=0.01)  # Table I: secondary battery, 485 min
    # The paper's own discretisation: 1 Hz, theta = 1, so one step is 1/60 simulated minute.
    u = np.zeros(1)
    steps = 0
    while u[0] < 1.0:
        u = step_battery(u, np.ones(1, bool), ACT, SEC, 1.0, 1.0)
        steps += 1
    step_min = 1 / 60
    assert abs(steps * step_min - t_full_min) <= step_min
    assert u[0] == 1.0  # clamped


@pytest.mark.parametrize("threshold, low, high", [(BANDS[0], RATES[0], RATES[1]), (BANDS[1], RATES[1], RATES[2])])
def test_charge_band_switches_exactly_at_the_threshold(threshold: float, low: float, high: float) -> None:
    dt_min = 30 / 60
    at = one(threshold, True)
    assert at - threshold == pytest.approx(low * dt_min, abs=1e-15)
    above = np.nextafter(threshold, 1.0)
    assert one(above, True) - above == pytest.approx(high * dt_min, abs=1e-15)
    below = np.nextafter(threshold, 0.0)
    assert one(below, True) - below == pytest.approx(low * dt_min, abs=1e-15)


def test_band_uses_the_value_before_the_step() -> None:
    # Starts in the lowest band and ends above its threshold: the whole step uses the low rate.
    u0 = BANDS[0] - 0.0001
    assert one(u0, True) - u0 == pytest.approx(RATES[0] * 0.5, abs=1e-15)


@pytest.mark.parametrize(
    "name, minutes",
    [("active_idle_table", 962.0), ("sleep", 14057.0)],
)
def test_table1_discharge_profiles_empty_after_their_time(name: str, minutes: float) -> None:
    prof = discharge_profile(name)
    theta, dt_s = 600.0, 1.0  # one step = 10 simulated minutes, to keep the loop short
    step_min = theta * dt_s / 60
    u = np.ones(1)
    steps = 0
    while u[0] > 0:
        u = step_battery(u, np.zeros(1, bool), prof, SEC, theta, dt_s)
        steps += 1
    assert abs(steps - minutes / step_min) <= 1


@pytest.mark.parametrize(
    "name, minutes",
    [("primary_idle", 575.0), ("primary_sleep", 398.0), ("secondary_table", 485.0)],
)
def test_table1_charge_profiles_full_after_their_time(name: str, minutes: float) -> None:
    prof = charge_profile(name)
    theta, dt_s = 60.0, 1.0  # one step = one simulated minute
    u = np.zeros(1)
    steps = 0
    while u[0] < 1:
        u = step_battery(u, np.ones(1, bool), ACT, prof, theta, dt_s)
        steps += 1
    assert abs(steps - minutes) <= 1


def test_unknown_profile_names_fail_with_the_choices() -> None:
    with pytest.raises(ValueError, match="sleep"):
        discharge_profile("nap")
    with pytest.raises(ValueError, match="secondary"):
        charge_profile("fast")


def test_millivolts_map_the_paper_window() -> None:
    np.testing.assert_array_equal(to_millivolts([0.0, 0.5, 1.0]), [3600.0, 3900.0, 4200.0])
    np.testing.assert_allclose(from_millivolts([3500.0, 3750.0, 4300.0]), [0.0, 0.25, 1.0])


unit = st.floats(0.0, 1.0, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(
    u=arrays(np.float64, st.integers(1, 40), elements=unit),
    data=st.data(),
    theta=st.floats(0.01, 500.0),
    dt_s=st.floats(0.001, 120.0),
    discharge=st.sampled_from(sorted(DISCHARGE_PROFILES)),
    charge=st.sampled_from(sorted(CHARGE_PROFILES)),
)
def test_battery_properties(
    u: np.ndarray, data: st.DataObject, theta: float, dt_s: float, discharge: str, charge: str
) -> None:
    charging = data.draw(arrays(np.bool_, u.shape))
    before = u.copy()
    out = step_battery(u, charging, DISCHARGE_PROFILES[discharge], CHARGE_PROFILES[charge], theta, dt_s)
    assert ((out >= 0.0) & (out <= 1.0)).all()
    assert (out[~charging] <= u[~charging]).all()  # never charges while not docked
    assert (out[charging] >= u[charging]).all()  # never discharges while docked
    np.testing.assert_array_equal(u, before)  # pure: the input is untouched
