"""The fleet step: state transitions, safety, uptime (eq. (3)), determinism, purity."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from mussel_sim.fleet import step
from mussel_sim.fleet_state import FleetInputs, FleetParams, FleetState, state_from_arrays
from mussel_sim.recorder import Recorder
from mussel_sim.vocabulary import MusselState as S

ACTIVE_RATE = 0.0010427134  # eq. (1)
STILL = FleetParams(drift_half_width_m=0.0)  # positions change only by what a test does


def fleet(n: int = 3, battery: float = 0.9, params: FleetParams = STILL) -> FleetState:
    """aMussels 1..n at (10 i, 0) m."""
    ids = np.arange(1, n + 1)
    return state_from_arrays(ids, 10.0 * ids, np.zeros(n), np.full(n, battery), params)


def run(
    state: FleetState, inputs: FleetInputs, steps: int = 1, params: FleetParams = STILL, seed: int = 0
) -> FleetState:
    rng = np.random.default_rng(seed)
    state, _ = step(state, inputs, params, rng, 1.0)
    for _ in range(steps - 1):
        state, _ = step(state, FleetInputs(inputs.apad_ids, inputs.apad_x_m, inputs.apad_y_m), params, rng, 1.0)
    return state


def states(s: FleetState) -> list[S]:
    return [S(v) for v in s.state]


# --- surfacing and the acoustic-range safety rule ------------------------------------------------


def test_surface_refused_without_any_apad() -> None:
    s, ev = step(fleet(), FleetInputs.make(surface=[2]), STILL, np.random.default_rng(0), 1.0)
    assert states(s) == [S.ACTIVE] * 3
    np.testing.assert_array_equal(ev.surface_refused_out_of_range_ids, [2])
    assert ev.surface_accepted_ids.size == 0


def test_surface_refused_with_apad_out_of_acoustic_range() -> None:
    # aMussel 2 at (20, 0); aPad 101 m away (just outside the default 100 m).
    inp = FleetInputs.make(apads={1: (20.0, 101.0)}, surface=[2])
    s, ev = step(fleet(), inp, STILL, np.random.default_rng(0), 1.0)
    assert s.state[1] == S.ACTIVE
    np.testing.assert_array_equal(ev.surface_refused_out_of_range_ids, [2])


def test_surface_accepted_with_apad_in_range_then_floats_after_surfacing_time() -> None:
    inp = FleetInputs.make(apads={1: (-40.0, 0.0), 2: (20.0 + 60.0, 80.0)}, surface=[2])  # aPad 2 at 100 m
    s, ev = step(fleet(), inp, STILL, np.random.default_rng(0), 1.0)
    np.testing.assert_array_equal(ev.surface_accepted_ids, [2])
    assert states(s) == [S.ACTIVE, S.SURFACING, S.ACTIVE]
    rng = np.random.default_rng(0)
    seen = [S(s.state[1])]
    for _ in range(19):
        s, ev = step(s, FleetInputs(), STILL, rng, 1.0)
        seen.append(S(s.state[1]))
    # 20 s of mission time: SURFACING at the end of steps 1..19, FLOATING at the end of step 20.
    assert seen[:19] == [S.SURFACING] * 19
    assert seen[19] == S.FLOATING
    assert s.depth_m[1] == 0.0


def test_depth_falls_linearly_while_surfacing() -> None:
    p = FleetParams(drift_half_width_m=0.0, seabed_depth_m=4.0, surfacing_time_s=8.0)
    s = run(fleet(params=p), FleetInputs.make(apads={1: (0.0, 0.0)}, surface=[1]), steps=2, params=p)
    assert s.depth_m[0] == pytest.approx(4.0 * (8 - 2) / 8)


def test_depleted_cannot_surface_and_is_reported() -> None:
    s = fleet(battery=0.0)
    assert states(s) == [S.DEPLETED] * 3
    s, ev = step(s, FleetInputs.make(apads={1: (10.0, 0.0)}, surface=[1]), STILL, np.random.default_rng(0), 1.0)
    assert s.state[0] == S.DEPLETED
    np.testing.assert_array_equal(ev.surface_refused_depleted_ids, [1])


def test_unknown_ids_and_meaningless_commands_are_reported() -> None:
    inp = FleetInputs.make(apads={1: (0.0, 0.0)}, surface=[99], sink=[1], release=[2])
    s, ev = step(fleet(), inp, STILL, np.random.default_rng(0), 1.0)
    assert states(s) == [S.ACTIVE] * 3
    np.testing.assert_array_equal(ev.unknown_ids, [99])
    np.testing.assert_array_equal(ev.ignored_command_ids, [1])  # sink while ACTIVE


# --- sink, dock, release ------------------------------------------------------------------------------


def floating(n: int = 3) -> FleetState:
    ids = np.arange(1, n + 1)
    return state_from_arrays(ids, 10.0 * ids, np.zeros(n), np.full(n, 0.5), STILL, state=np.full(n, S.FLOATING))


def test_sink_command_takes_sinking_time_then_active() -> None:
    s = run(floating(), FleetInputs.make(sink=[3]), steps=19)
    assert s.state[2] == S.SINKING
    assert s.depth_m[2] == pytest.approx(STILL.seabed_depth_m * 19 / 20)
    s = run(s, FleetInputs(), steps=1)
    assert s.state[2] == S.ACTIVE
    assert s.depth_m[2] == STILL.seabed_depth_m


def test_docked_charges_and_follows_its_apad_then_sinks_on_release() -> None:
    s, ev = step(
        floating(), FleetInputs.make(apads={7: (33.0, 44.0)}, dock=[(2, 7, 3)]), STILL, np.random.default_rng(0), 1.0
    )
    np.testing.assert_array_equal(ev.docked_ids, [2])
    assert ev.docked_submerged_ids.size == 0
    assert states(s) == [S.FLOATING, S.DOCKED, S.FLOATING]
    assert (s.dock_apad[1], s.dock_slot[1]) == (7, 3)
    assert (s.x_m[1], s.y_m[1]) == (33.0, 44.0)
    # eq. (2), middle band (0.16197 < 0.5 <= 0.5634), theta = 30, 1 s: +0.00223 * 0.5
    assert s.battery_frac[1] == pytest.approx(0.5 + 0.00223 * 0.5, abs=1e-15)
    # Everyone else discharges at the active rate, eq. (1), floating or not.
    assert s.battery_frac[0] == pytest.approx(0.5 - ACTIVE_RATE * 0.5, abs=1e-15)
    # The aPad moves, the docked aMussel moves with it.
    s = run(s, FleetInputs.make(apads={7: (35.0, 40.0)}))
    assert (s.x_m[1], s.y_m[1]) == (35.0, 40.0)
    s, ev = step(s, FleetInputs.make(apads={7: (35.0, 40.0)}, release=[2]), STILL, np.random.default_rng(0), 1.0)
    np.testing.assert_array_equal(ev.released_ids, [2])
    assert s.state[1] == S.SINKING
    assert (s.dock_apad[1], s.dock_slot[1]) == (0, 0)
    s = run(s, FleetInputs.make(apads={7: (0.0, 0.0)}), steps=19)
    assert s.state[1] == S.ACTIVE  # released at step 1, 20 s of sinking in all
    assert (s.x_m[1], s.y_m[1]) == (35.0, 40.0)  # no longer follows the aPad


def test_docking_a_submerged_mussel_is_honoured_but_reported() -> None:
    s, ev = step(fleet(), FleetInputs.make(dock=[(1, 2, 1)]), STILL, np.random.default_rng(0), 1.0)
    assert s.state[0] == S.DOCKED
    np.testing.assert_array_equal(ev.docked_submerged_ids, [1])
    # No aPad position known yet: it stays where it was.
    assert (s.x_m[0], s.y_m[0]) == (10.0, 0.0)


def test_depleted_mussel_docked_anyway_charges_and_becomes_docked() -> None:
    s, _ = step(fleet(battery=0.0), FleetInputs.make(dock=[(3, 1, 4)]), STILL, np.random.default_rng(0), 1.0)
    assert states(s) == [S.DEPLETED, S.DEPLETED, S.DOCKED]
    assert s.battery_frac[2] == pytest.approx(0.001045 * 0.5, abs=1e-15)  # lowest band of eq. (2)
    assert s.battery_frac[0] == 0.0


def test_active_mussel_depletes_at_step_1919_with_theta_30() -> None:
    # 1 / 0.0010427134 = 959.04 simulated minutes = 1918.07 s of mission time at theta = 30.
    expected_step = math.ceil((1 / ACTIVE_RATE) * 60 / 30)
    assert expected_step == 1919
    s = fleet(n=1, battery=1.0)
    rng = np.random.default_rng(0)
    k = 0
    while s.state[0] == S.ACTIVE:
        s, ev = step(s, FleetInputs(), STILL, rng, 1.0)
        k += 1
    assert k == expected_step
    assert s.state[0] == S.DEPLETED
    np.testing.assert_array_equal(ev.depleted_ids, [1])
    s, _ = step(s, FleetInputs(), STILL, rng, 1.0)
    assert (s.battery_frac[0], s.state[0]) == (0.0, S.DEPLETED)


def test_docked_from_empty_is_full_after_the_eq2_time() -> None:
    t_full_min = 0.16197 / 0.001045 + (0.5634 - 0.16197) / 0.00223 + (1 - 0.5634) / 0.002911
    s = run(fleet(n=1, battery=0.0), FleetInputs.make(dock=[(1, 1, 1)]))
    k = 1
    rng = np.random.default_rng(0)
    while s.battery_frac[0] < 1.0:
        s, _ = step(s, FleetInputs(), STILL, rng, 1.0)
        k += 1
    step_min = 30 / 60
    # Never early; late by under one step per band boundary crossed (2) plus the last partial step.
    assert t_full_min <= k * step_min < t_full_min + 3 * step_min
    assert s.state[0] == S.DOCKED


# --- uptime, eq. (3) -------------------------------------------------------------------------------


def test_uptime_matches_a_hand_computed_case() -> None:
    # 10 steps. aMussel 1: active throughout -> 100 %. aMussel 2: called up in step 4 (surfacing
    # takes 2 s) -> active at the end of steps 1-3 only -> 30 %. aMussel 3: u just above one step's
    # discharge for 1.5 steps -> depletes in step 2, active at the end of step 1 only -> 10 %.
    p = FleetParams(drift_half_width_m=0.0, surfacing_time_s=2.0)
    one_step = ACTIVE_RATE * 30 / 60
    s = state_from_arrays([1, 2, 3], [0.0, 10.0, 20.0], [0.0, 0.0, 0.0], [1.0, 1.0, 1.5 * one_step], p)
    rec = Recorder(s.ids)
    rng = np.random.default_rng(0)
    for k in range(1, 11):
        inp = FleetInputs.make(apads={1: (0.0, 0.0)}, surface=[2] if k == 4 else [])
        s, _ = step(s, inp, p, rng, 1.0)
        rec.record(s)
    np.testing.assert_allclose(rec.uptime_pct(), [100.0, 30.0, 10.0])
    np.testing.assert_array_equal(rec.active_count(), [3, 2, 2, 1, 1, 1, 1, 1, 1, 1])
    summary = rec.summary()
    assert summary.n_steps == 10
    assert summary.avg_uptime_pct == pytest.approx(140 / 3)
    assert (summary.max_uptime_pct, summary.min_uptime_pct) == (100.0, 10.0)
    assert summary.avg_active == pytest.approx(1.4)
    np.testing.assert_array_equal(rec.step_time_us(), np.arange(1, 11) * 1_000_000)


def test_battery_traces_stay_within_their_memory_budget_and_evenly_sampled() -> None:
    n = 1000
    s = fleet(n=n, battery=1.0)
    budget = 40 * n * 4  # room for 40 rows of float32
    rec = Recorder(s.ids, max_trace_bytes=budget)
    rng = np.random.default_rng(0)
    for _ in range(200):
        s, _ = step(s, FleetInputs(), STILL, rng, 1.0)
        rec.record(s)
    steps, trace = rec.battery_trace()
    assert trace.nbytes <= budget
    assert trace.shape == (steps.size, n)
    stride = rec.trace_stride
    np.testing.assert_array_equal(steps, np.arange(0, 200, stride))
    # Row for step k (0-based) is u after k + 1 steps of eq. (1).
    np.testing.assert_allclose(trace[:, 0], 1.0 - (steps + 1) * ACTIVE_RATE * 0.5, rtol=1e-6)


def test_traces_of_selected_mussels_only() -> None:
    s = fleet(n=5)
    rec = Recorder(s.ids, trace_ids=[2, 5])
    s2, _ = step(s, FleetInputs(), STILL, np.random.default_rng(0), 1.0)
    rec.record(s2)
    _, trace = rec.battery_trace()
    np.testing.assert_array_equal(trace, s2.battery_frac[[1, 4]][None, :].astype(np.float32))
    with pytest.raises(ValueError):
        Recorder(s.ids, trace_ids=[6])


# --- determinism and purity --------------------------------------------------------------------------


def scenario_run(seed: int) -> FleetState:
    p = FleetParams()  # with the paper's random drift
    rng = np.random.default_rng(seed)
    ids = np.arange(1, 201)
    s = state_from_arrays(ids, rng.uniform(0, 50, 200), rng.uniform(0, 50, 200), rng.uniform(0.6, 1.0, 200), p)
    for k in range(120):
        inp = FleetInputs.make(
            apads={1: (25.0, 25.0)},
            surface=[k % 200 + 1],
            dock=[(k % 200 - 20 + 1, 1, 1)] if k >= 20 else [],
            release=[k % 200 - 40 + 1] if k >= 40 else [],
        )
        s, _ = step(s, inp, p, rng, 1.0)
    return s


def test_same_seed_same_fleet_bit_for_bit() -> None:
    a, b, c = scenario_run(42), scenario_run(42), scenario_run(43)
    assert a.arrays_equal(b)
    assert a.x_m.tobytes() == b.x_m.tobytes()
    assert not a.arrays_equal(c)


def test_step_is_pure() -> None:
    s = fleet(n=4)
    snapshot = {name: getattr(s, name).copy() for name in ("x_m", "battery_frac", "state", "timer_s")}
    inp = FleetInputs.make(apads={1: (0.0, 0.0)}, surface=[1], dock=[(2, 1, 1)])
    step(s, inp, FleetParams(), np.random.default_rng(0), 1.0)
    for name, before in snapshot.items():
        np.testing.assert_array_equal(getattr(s, name), before)
    with pytest.raises(ValueError):
        s.battery_frac[0] = 0.0  # state arrays are read-only views


# --- properties of the whole step -----------------------------------------------------------------


@settings(max_examples=100, deadline=None)
@given(
    u=arrays(np.float64, 12, elements=st.floats(0.0, 1.0)),
    start=arrays(np.uint8, 12, elements=st.sampled_from([int(S.ACTIVE), int(S.FLOATING), int(S.DEPLETED)])),
    docked=arrays(np.bool_, 12),
    theta=st.floats(0.1, 200.0),
)
def test_step_properties(u: np.ndarray, start: np.ndarray, docked: np.ndarray, theta: float) -> None:
    p = FleetParams(theta=theta)
    ids = np.arange(1, 13)
    s = state_from_arrays(ids, np.zeros(12), np.zeros(12), u, p, state=start)
    dock_ids = ids[docked]
    s, _ = step(s, FleetInputs.make(dock=[(int(i), 1, 1) for i in dock_ids]), p, np.random.default_rng(0), 1.0)
    before = s.battery_frac.copy()
    was = s.state.copy()
    s, _ = step(s, FleetInputs(), p, np.random.default_rng(1), 1.0)
    assert ((s.battery_frac >= 0) & (s.battery_frac <= 1)).all()
    assert (s.battery_frac[was == S.ACTIVE] <= before[was == S.ACTIVE]).all()  # never charges while active
    assert (s.battery_frac[was == S.DOCKED] >= before[was == S.DOCKED]).all()  # never discharges docked
    assert (s.state[s.battery_frac == 0] != S.ACTIVE).all()  # at 0 an aMussel is never active
