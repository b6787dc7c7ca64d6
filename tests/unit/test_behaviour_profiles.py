"""aMussel behaviour profiles (issue 20): Table I's times through the real fleet step, the duty-cycle
model of a sleep order at its two calibration points, the wake schedule, call-ups held till a wake,
samples, and the scenario's profile fields."""

from __future__ import annotations

import math
import tomllib
from typing import Any

import numpy as np
import pytest
from testkit import MISSIONS

from gcs.scenario.model_params import call_up_wait_s, check_inputs, fleet_params
from gcs.scenario.reader import ScenarioError, scenario_from_data
from mussel_sim.battery import (
    DISCHARGE_ACTIVE_PER_MIN,
    TABLE1_CHARGE_PRIMARY_IDLE_MIN,
    TABLE1_CHARGE_PRIMARY_SLEEP_MIN,
    TABLE1_CHARGE_SECONDARY_MIN,
    TABLE1_DISCHARGE_ACTIVE_IDLE_MIN,
    TABLE1_DISCHARGE_SLEEP_MIN,
)
from mussel_sim.behaviour import (
    HOURLY_WAKE_AWAKE_S,
    HOURLY_WAKE_INTERVAL_S,
    ON_PER_MIN,
    SLEEP_PER_MIN,
    duty_cycle_rate_per_min,
    hourly_wake,
    sleep_order_problem,
)
from mussel_sim.fleet import step
from mussel_sim.fleet_state import FleetInputs, FleetParams, FleetState, state_from_arrays
from mussel_sim.recorder import Recorder
from mussel_sim.vocabulary import MusselState
from mussel_sim.wake import next_wake_s, phase

# theta 60 and 1 s steps: one simulated minute per step, so a step count is Table I's minutes.
MINUTE = FleetParams(theta=60.0, drift_half_width_m=0.0)
NO_DRIFT = FleetParams(drift_half_width_m=0.0, profile="hourly_wake")  # theta 30, every aMussel sleeping
QUIET = FleetInputs()


def _fleet(params: FleetParams, ids: list[int], battery: float, x_m: float = 0.0) -> FleetState:
    return state_from_arrays(ids, [x_m] * len(ids), [0.0] * len(ids), [battery] * len(ids), params)


def _run(state: FleetState, params: FleetParams, steps: int, inputs: FleetInputs = QUIET) -> FleetState:
    rng = np.random.default_rng(0)
    for _ in range(steps):
        state, _ = step(state, inputs, params, rng, 1.0)
    return state


def test_each_profile_empties_in_its_table_i_time_driving_the_fleet_step() -> None:
    """aMussel 1 always on (eq. (1): 959.04 min; Table I measured 962), aMussel 2 waking hourly
    (Table I: 14,057 min), in one fleet from full; each the minute (step) it depleted."""
    params = FleetParams(theta=60.0, drift_half_width_m=0.0, profile_ids=(("hourly_wake", (2,)),))
    state = _fleet(params, [1, 2], 1.0)
    rng = np.random.default_rng(0)
    depleted: dict[int, int] = {}
    for minute in range(1, 14_100):
        state, events = step(state, QUIET, params, rng, 1.0)
        depleted |= {int(i): minute for i in events.depleted_ids}
        if len(depleted) == 2:
            break
    assert depleted[1] == math.ceil(1.0 / DISCHARGE_ACTIVE_PER_MIN) == 960  # eq. (1), as today
    assert abs(depleted[1] - TABLE1_DISCHARGE_ACTIVE_IDLE_MIN) / TABLE1_DISCHARGE_ACTIVE_IDLE_MIN < 0.005
    assert abs(depleted[2] - TABLE1_DISCHARGE_SLEEP_MIN) <= 1
    # It sampled at each hourly wake while on the seabed (wakes at (k + phase) h): 235 in its 14,057 min.
    wakes = math.floor(depleted[2] / 60 - float(phase([2])[0])) + 1
    assert state.samples_due[1] == state.samples_taken[1] == wakes == 235
    assert state.samples_due[0] == state.samples_taken[0] == 0  # always on: monitoring, not sampling


@pytest.mark.parametrize("params, minutes", [
    (FleetParams(theta=60.0), TABLE1_CHARGE_SECONDARY_MIN),  # always_on: eq. (2), 484.99 min
    (FleetParams(theta=60.0, charge_profile="secondary_table"), TABLE1_CHARGE_SECONDARY_MIN),
    (FleetParams(theta=60.0, charge_profile="primary_idle"), TABLE1_CHARGE_PRIMARY_IDLE_MIN),
    (FleetParams(theta=60.0, profile="hourly_wake"), TABLE1_CHARGE_PRIMARY_SLEEP_MIN),  # its own: 398 min
    (FleetParams(theta=60.0, profile="hourly_wake", sleep_charge_profile="primary_idle"),
     TABLE1_CHARGE_PRIMARY_IDLE_MIN),  # "or as the scenario says"
], ids=["always_on", "always_on-secondary_table", "always_on-primary_idle", "hourly_wake",
        "hourly_wake-primary_idle"])
def test_each_charge_profile_fills_a_docked_amussel_in_its_table_i_time(params: FleetParams, minutes: float) -> None:
    state = _fleet(params, [7], 0.0)
    assert state.state[0] == MusselState.DEPLETED
    state, _ = step(state, FleetInputs.make(dock=[(7, 1, 1)]), params, np.random.default_rng(0), 1.0)
    rng, minute = np.random.default_rng(0), 1
    while state.battery_frac[0] < 1.0 and minute < 2 * minutes:
        state, _ = step(state, QUIET, params, rng, 1.0)
        minute += 1
    assert state.state[0] == MusselState.DOCKED
    assert abs(minute - minutes) <= 1, minute


def test_the_duty_cycle_model_holds_both_table_i_points_and_lies_between_them() -> None:
    hourly = duty_cycle_rate_per_min(HOURLY_WAKE_INTERVAL_S, HOURLY_WAKE_AWAKE_S)
    assert 1.0 / hourly == pytest.approx(TABLE1_DISCHARGE_SLEEP_MIN, rel=1e-12)  # 14,057 min
    assert 1.0 / duty_cycle_rate_per_min(600.0, 600.0) == pytest.approx(TABLE1_DISCHARGE_ACTIVE_IDLE_MIN, rel=1e-12)
    assert duty_cycle_rate_per_min(0.0, 0.0) == pytest.approx(ON_PER_MIN, rel=1e-12)  # interval 0: always on
    assert 0.0 < SLEEP_PER_MIN < hourly < ON_PER_MIN
    assert pytest.approx(14_611, abs=1) == 1.0 / SLEEP_PER_MIN  # asleep throughout, an extrapolation
    rates = [duty_cycle_rate_per_min(3600.0, a) for a in (0.0, 10.0, 60.0, 600.0, 3600.0)]
    assert rates == sorted(rates) and rates[0] == pytest.approx(SLEEP_PER_MIN)
    # The hourly_wake profile is Table I's row itself; the model's value at its point agrees.
    assert hourly_wake().discharge.rate_per_min == pytest.approx(hourly, rel=1e-12)


@pytest.mark.parametrize("interval, awake, why", [
    (-1.0, 0.0, "interval"), (math.nan, 1.0, "interval"), (math.inf, 1.0, "interval"), (0.5, 0.1, "interval"),
    (3600.0, math.nan, "awake"), (3600.0, -1.0, "awake"), (100.0, 200.0, "awake_over_interval"),
    (3600.0, 10.0, None), (0.0, 0.0, None), (60.0, 60.0, None),
])
def test_a_sleep_order_is_checked_field_by_field(interval: float, awake: float, why: str | None) -> None:
    assert sleep_order_problem(interval, awake) == why


def test_the_next_wake_is_the_step_in_which_the_fleet_wakes_and_samples() -> None:
    """next_wake_s, a pure function of id, schedule and time, against the fleet step's own count."""
    ids = [1, 2, 3, 17, 120]
    state = _fleet(NO_DRIFT, ids, 1.0)
    first_sample: dict[int, int] = {}
    rng = np.random.default_rng(0)
    for t in range(1, 125):
        state, _ = step(state, QUIET, NO_DRIFT, rng, 1.0)
        first_sample |= {int(i): t for i, n in zip(state.ids, state.samples_due, strict=True)
                         if n and int(i) not in first_sample}
    for i in ids:
        t_w = next_wake_s(i, HOURLY_WAKE_INTERVAL_S, HOURLY_WAKE_AWAKE_S, 0.5, NO_DRIFT.theta)
        assert 0.5 < t_w <= 120.5 and first_sample[i] == math.ceil(t_w), i
    assert len({first_sample[i] for i in ids}) == len(ids)  # the phases from the ids spread the wakes
    # Every wake of the next two minutes is a sample too (one each: a wake every 120 mission s).
    assert (state.samples_due == 1).all() and (state.samples_taken == 1).all()
    assert next_wake_s(5, None, None, 42.0, 30.0) == 42.0  # always on: awake now


def _asleep_start(mussel_id: int) -> tuple[FleetState, float]:
    """One sleeping aMussel with an aPad beside it, stepped to a time it is asleep; its next wake."""
    state = _fleet(NO_DRIFT, [mussel_id], 0.9)
    state = _run(state, NO_DRIFT, 3)
    t_w = next_wake_s(mussel_id, HOURLY_WAKE_INTERVAL_S, HOURLY_WAKE_AWAKE_S, state.time_s, NO_DRIFT.theta)
    assert t_w > state.time_s + 2  # asleep now, for a while
    return state, t_w


APAD_NEAR = {1: (5.0, 0.0)}


def test_a_call_up_to_a_sleeping_amussel_is_held_and_taken_at_its_wake() -> None:
    state, t_w = _asleep_start(4)
    rng = np.random.default_rng(0)
    state, events = step(state, FleetInputs.make(apads=APAD_NEAR, surface=[4]), NO_DRIFT, rng, 1.0)
    assert events.surface_held_ids.tolist() == [4] and events.surface_accepted_ids.size == 0
    assert state.state[0] == MusselState.ACTIVE and state.surface_held[0]
    while state.time_s < t_w:
        before = state
        state, events = step(state, FleetInputs.make(apads=APAD_NEAR), NO_DRIFT, rng, 1.0)
    assert before.state[0] == MusselState.ACTIVE and before.time_s < t_w  # asleep till the last step before
    assert events.surface_accepted_ids.tolist() == [4]  # the step of its wake
    assert state.state[0] == MusselState.SURFACING and not state.surface_held[0]
    assert state.time_s - t_w < 1.0


def test_a_sink_calls_a_held_call_up_off_and_a_wake_up_ping_takes_it_at_once() -> None:
    state, t_w = _asleep_start(4)
    rng = np.random.default_rng(0)
    state, _ = step(state, FleetInputs.make(apads=APAD_NEAR, surface=[4]), NO_DRIFT, rng, 1.0)
    state, _ = step(state, FleetInputs.make(apads=APAD_NEAR, sink=[4]), NO_DRIFT, rng, 1.0)
    assert not state.surface_held[0]
    state = _run(state, NO_DRIFT, math.ceil(t_w - state.time_s) + 2, FleetInputs.make(apads=APAD_NEAR))
    assert state.state[0] == MusselState.ACTIVE  # its wake came and went: nothing to take
    # The seam of the acoustic wake-up ping (FleetInputs.wake_ids): the held call-up goes at once.
    state, _ = step(state, FleetInputs.make(apads=APAD_NEAR, surface=[4]), NO_DRIFT, rng, 1.0)
    assert state.surface_held[0]
    state, events = step(state, FleetInputs.make(apads=APAD_NEAR, wake=[4]), NO_DRIFT, rng, 1.0)
    assert events.surface_accepted_ids.tolist() == [4] and state.state[0] == MusselState.SURFACING


def test_a_held_call_up_with_no_apad_in_range_at_the_wake_is_refused_then() -> None:
    state, t_w = _asleep_start(4)
    rng = np.random.default_rng(0)
    state, _ = step(state, FleetInputs.make(apads=APAD_NEAR, surface=[4]), NO_DRIFT, rng, 1.0)
    gone = FleetInputs.make(apads={1: (500.0, 0.0)})  # the aPad left: the safety check is at the wake
    refused: list[int] = []
    for _ in range(math.ceil(t_w - state.time_s) + 1):
        state, events = step(state, gone, NO_DRIFT, rng, 1.0)
        refused += events.surface_refused_out_of_range_ids.tolist()
    assert refused == [4] and state.state[0] == MusselState.ACTIVE and not state.surface_held[0]


def test_an_always_on_amussel_surfaces_at_once_as_before() -> None:
    state = _fleet(FleetParams(drift_half_width_m=0.0), [4], 0.9)
    state, events = step(state, FleetInputs.make(apads=APAD_NEAR, surface=[4]), FleetParams(drift_half_width_m=0.0),
                         np.random.default_rng(0), 1.0)
    assert events.surface_accepted_ids.tolist() == [4] and events.surface_held_ids.size == 0


def test_a_sleep_order_changes_discharge_and_schedule_and_samples_count_from_it() -> None:
    params = FleetParams(theta=60.0, drift_half_width_m=0.0)
    state = _fleet(params, [1, 2], 1.0)
    state = _run(state, params, 1, FleetInputs.make(sleep=[(2, 600.0, 60.0)]))
    assert state.profiles.profiles[state.profile[1]].name == "always_on+order:600s/60s"
    state = _run(state, params, 600)  # 600 simulated minutes
    rate = duty_cycle_rate_per_min(600.0, 60.0)
    assert 1.0 - state.battery_frac[1] == pytest.approx(601 * rate, rel=1e-9)  # from the step it arrived in
    assert 1.0 - state.battery_frac[0] == pytest.approx(601 * DISCHARGE_ACTIVE_PER_MIN, rel=1e-9)
    assert state.samples_due[1] == state.samples_taken[1] == 60  # a wake every 10 simulated minutes
    # Interval 0: always on again, at the model's duty 1 (Table I's 962 min), no more samples.
    state = _run(state, params, 10, FleetInputs.make(sleep=[(2, 0.0, 0.0)]))
    assert state.profiles.rate_per_min[state.profile[1]] == pytest.approx(ON_PER_MIN)
    assert not state.profiles.scheduled[state.profile[1]] and state.samples_due[1] == 60


def test_the_recorder_counts_samples_and_keeps_them_across_a_restore() -> None:
    state = _fleet(NO_DRIFT, [1, 2, 3], 1.0)
    rec = Recorder(state.ids)
    rng = np.random.default_rng(0)
    for _ in range(300):
        state, _ = step(state, QUIET, NO_DRIFT, rng, 1.0)
        rec.record(state, 1_000_000)
    taken, due = rec.samples()
    # A wake every 120 s at (k + phase) x 120 s: in (0, 300] two or three, by the id's phase.
    assert due.tolist() == [math.floor(300 / 120 - p) + 1 for p in phase([1, 2, 3])] and due.min() >= 2
    assert taken.tolist() == due.tolist() and (rec.uptime_pct() == 100.0).all()  # asleep on the seabed: up
    back = Recorder.restore(rec.head(), rec.rows_since(0))
    assert [a.tolist() for a in back.samples()] == [taken.tolist(), due.tolist()]


# --- the scenario's fields -------------------------------------------------------------------------------

def _pool12(**fleet: Any) -> dict[str, Any]:
    data = tomllib.loads((MISSIONS / "pool12.toml").read_text())
    data["fleet"] |= fleet
    return data


def _error(data: dict[str, Any]) -> str:
    with pytest.raises(ScenarioError) as err:
        check_inputs(scenario_from_data(MISSIONS / "pool12.toml", data))
    text = str(err.value)
    assert "\n" not in text
    return text.split(": ", 1)[1]


def test_the_scenario_picks_profiles_for_all_and_per_amussel() -> None:
    default = scenario_from_data(MISSIONS / "pool12.toml", _pool12())
    assert (default.fleet.profile, default.fleet.profiles) == ("always_on", ())
    s = scenario_from_data(MISSIONS / "pool12.toml", _pool12(profile="hourly_wake", profiles={"always_on": [3, 5]}))
    check_inputs(s)
    params = fleet_params(s)
    ids = np.arange(1, 13)
    names = [params.profile_table.profiles[k].name for k in params.start_profiles(ids)]
    assert [i for i, n in zip(ids, names, strict=True) if n == "always_on"] == [3, 5]
    assert names.count("hourly_wake") == 10
    assert params.profile_table.profiles[1].charge.name == "primary_sleep"
    assert call_up_wait_s(s, 120.0) == 120.0 + 2 * s.fleet.surfacing_time_s  # a wake is 2 min away at most
    assert call_up_wait_s(default, 120.0) == 120.0


@pytest.mark.parametrize("fleet, message", [
    ({"profile": "nap"}, "fleet.profile: 'nap' is not one of always_on, hourly_wake"),
    ({"profiles": {"nap": [1]}}, "fleet.profiles.nap: unknown field"),
    ({"profiles": {"hourly_wake": [13]}}, "fleet.profiles.hourly_wake: aMussel 13 is not in the simulated fleet"),
    ({"profiles": {"hourly_wake": [0]}}, "fleet.profiles.hourly_wake: 0 is outside [1, 65535]"),
    ({"profiles": {"always_on": [2], "hourly_wake": [4, 2]}},
     "fleet.profiles.hourly_wake: aMussel 2 is also under always_on"),
    ({"profiles": {"hourly_wake": 3}}, "fleet.profiles.hourly_wake: expected a list of integers"),
    ({"profiles": [3]}, "fleet.profiles: expected a table"),
    ({"sleep_charge": "fast"}, "fleet.sleep_charge: 'fast' is not one of"),
])
def test_a_bad_profile_field_is_one_line_naming_it(fleet: dict[str, Any], message: str) -> None:
    assert _error(_pool12(**fleet)).startswith(message)


def test_a_scenario_sets_the_sleepers_wake_schedule_and_table_is_is_the_default() -> None:
    """fleet.wake_interval_s / fleet.awake_s: Table I's schedule unless set (the same profile, bit for bit);
    another drains by the duty-cycle model and wakes at its own interval, in the fleet step."""
    assert FleetParams(profile="hourly_wake").profile_table.profiles[1] == hourly_wake()
    half_hour = FleetParams(theta=60.0, drift_half_width_m=0.0, profile="hourly_wake", wake_interval_s=1800.0,
                            awake_s=10.0)
    sleeper = half_hour.profile_table.profiles[1]
    assert sleeper.name == "hourly_wake" and (sleeper.wake_interval_s, sleeper.awake_s) == (1800.0, 10.0)
    assert sleeper.discharge.rate_per_min == duty_cycle_rate_per_min(1800.0, 10.0) > 1 / TABLE1_DISCHARGE_SLEEP_MIN
    state = _run(_fleet(half_hour, [1, 2], 1.0), half_hour, 120)  # two simulated hours: four wakes each
    assert state.battery_frac == pytest.approx(1.0 - 120 * duty_cycle_rate_per_min(1800.0, 10.0), abs=1e-12)
    assert list(state.samples_taken) == [4, 4]


@pytest.mark.parametrize(("fields", "said"), [
    ({"wake_interval_s": 600, "awake_s": 600}, "fleet.awake_s: expected less than wake_interval_s (600 s)"),
    ({"wake_interval_s": 10}, "fleet.wake_interval_s"),
    ({"awake_s": 0}, "fleet.awake_s"),
])
def test_a_bad_wake_schedule_is_one_line(fields: dict[str, Any], said: str) -> None:
    data = tomllib.loads((MISSIONS / "bay-capacity.toml").read_text())
    data["fleet"] |= fields
    with pytest.raises(ScenarioError) as caught:
        scenario_from_data(MISSIONS / "bay-capacity.toml", data)
    assert said in str(caught.value) and "\n" not in str(caught.value)
