"""Records of long missions: figures per simulated day, counted at every step and checked against a
count made here from the states themselves; the trace stores hold a fixed number of rows whatever
the mission's length (a property of the data structures, not a timing)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gcs.mission.apad_record import ApadRecord, ThinnedSeries
from gcs.results.days import groups
from mussel_sim.day_ledger import DayLedger, day_us
from mussel_sim.fleet_state import (
    ACTIVE,
    DEPLETED,
    DOCKED,
    SINKING,
    SURFACING,
    FleetParams,
    FleetState,
    state_from_arrays,
)
from mussel_sim.recorder import Recorder

N = 5
STATES = np.array([ACTIVE, SURFACING, DOCKED, SINKING, DEPLETED], np.uint8)


def states(steps: int, seed: int, dt_us: int = 1_000_000) -> list[FleetState]:
    """`steps` fleet states `dt_us` apart in random states (depletion comes and goes: a docked one recovers)."""
    rng = np.random.default_rng(seed)
    ids = np.arange(1, N + 1)
    base = state_from_arrays(ids, 10.0 * ids, np.zeros(N), np.full(N, 0.9), FleetParams())
    return [replace(base, time_us=(k + 1) * dt_us, battery_frac=rng.random(N),
                    state=STATES[rng.integers(0, STATES.size, N)]) for k in range(steps)]


def test_a_sim_day_is_86400_s_over_theta() -> None:
    assert day_us(30.0) == 2_880_000_000  # 48 min: a 24-h mission is 30 simulated days
    assert day_us(1.0) == 86_400_000_000


@given(steps=st.integers(1, 120), day_s=st.integers(1, 40), seed=st.integers(0, 10**6))
@settings(max_examples=60, deadline=None)
def test_per_day_figures_are_those_counted_from_the_states_themselves(steps: int, day_s: int, seed: int) -> None:
    run = states(steps, seed)
    rec = Recorder(np.arange(1, N + 1), day_us=day_s * 1_000_000)
    for s in run:
        rec.record(s)
    days = rec.days
    assert days is not None
    # Here: a step ending at t (s) counts in day ceil(t / day_s) - 1; its active count, who is alive.
    t = np.array([s.time_us for s in run]) // 1_000_000
    day = (t - 1) // day_s
    n_days = int(day[-1]) + 1
    active = np.array([np.count_nonzero(np.isin(s.state, [ACTIVE, SINKING])) for s in run])
    alive = np.array([np.count_nonzero(s.state != DEPLETED) for s in run])
    ever = np.zeros(N, bool)
    first = []
    for s in run:
        newly = (s.state == DEPLETED) & ~ever
        ever |= newly
        first.append(int(np.count_nonzero(newly)))
    assert len(days.steps) == n_days
    for d in range(n_days):
        mine = day == d
        assert days.steps[d] == np.count_nonzero(mine)
        assert days.active_sum[d] == active[mine].sum()
        assert days.depleted_new[d] == np.array(first)[mine].sum()
        assert days.alive_end[d] == alive[mine][-1]  # the day's last step
        assert days.uptime_pct(N)[d] == pytest.approx(100.0 * active[mine].mean() / N)
    spans = days.spans_s()
    assert spans[0][0] == 0.0 and spans[-1][1] == t[-1]  # the last day ends at the last step
    assert all(b - a == day_s for a, b in spans[:-1])  # the others are whole days
    # Every step is in exactly one day, and eq. (3) over the whole run is the steps' mean of the days.
    assert sum(days.steps) == steps
    assert np.average(days.uptime_pct(N), weights=days.steps) == pytest.approx(rec.summary().avg_uptime_pct)


def test_the_day_ledger_survives_a_checkpoint_split() -> None:
    run = states(50, 3)
    rec = Recorder(np.arange(1, N + 1), day_us=7_000_000, max_trace_rows=8)
    for s in run[:31]:
        rec.record(s)
    back = Recorder.restore(rec.head(), rec.rows_since(0))
    for s in run[31:]:
        rec.record(s)
        back.record(s)
    assert back.days == rec.days and back.days is not rec.days
    np.testing.assert_array_equal(back.state_trace()[1], rec.state_trace()[1])


@pytest.mark.parametrize("max_rows", [2, 8, 100])
def test_the_trace_store_holds_at_most_its_rows_whatever_the_duration(max_rows: int) -> None:
    run = states(1000, 5)
    rec = Recorder(np.arange(1, N + 1), max_trace_rows=max_rows)
    assert rec.max_trace_rows == max_rows
    for s in run:
        rec.record(s)
        steps, battery = rec.battery_trace()
        assert steps.size <= max_rows  # at every instant, not only at the end
    stride = rec.trace_stride
    assert stride & (stride - 1) == 0 and stride * max_rows >= len(run)  # a power of two: as few dropped as can be
    np.testing.assert_array_equal(steps, np.arange(0, len(run), stride))  # evenly spaced from the first step
    st_steps, state = rec.state_trace()
    np.testing.assert_array_equal(st_steps, steps)
    for row, k in enumerate(steps):  # each row is the state and battery of its own step
        np.testing.assert_array_equal(state[row], run[k].state)
        np.testing.assert_array_equal(battery[row], run[k].battery_frac.astype(np.float32))


def test_the_byte_budget_still_bounds_a_wide_fleet() -> None:
    rec = Recorder(np.arange(1, N + 1), max_trace_bytes=4 * N * 5, max_trace_rows=1000)
    for s in states(100, 1):
        rec.record(s)
    assert rec.battery_trace()[0].size <= 4


@given(offered=st.integers(0, 5000), max_rows=st.integers(2, 64))
@settings(max_examples=60, deadline=None)
def test_a_thinned_series_keeps_evenly_spaced_rows_within_its_bound(offered: int, max_rows: int) -> None:
    series = ThinnedSeries(2, max_rows)
    for k in range(offered):
        series.offer(k, [float(k), -float(k)])
        assert len(series.rows) <= max_rows
    a = series.array()
    assert a.shape == (len(series.rows), 2)
    np.testing.assert_array_equal(a[:, 0], np.arange(0, offered, series.stride)[: a.shape[0]])
    assert a.shape[0] == len(range(0, offered, series.stride))  # nothing at the stride lost
    np.testing.assert_array_equal(a[:, 1], -a[:, 0])


@pytest.mark.parametrize("n_days, max_rows, first_spans", [
    (5, 10, [1, 1, 1, 1, 1]), (30, 10, [3] * 10), (210, 10, [21] * 10), (31, 10, [4] * 7 + [3]),
])
def test_console_groups_of_days_cover_every_day_once(n_days: int, max_rows: int, first_spans: list[int]) -> None:
    spans = groups(n_days, max_rows)
    assert len(spans) <= max_rows and [len(s) for s in spans] == first_spans
    assert [d for s in spans for d in s] == list(range(n_days))


def test_an_event_at_a_day_boundary_counts_in_the_day_a_step_ending_there_does() -> None:
    """Dockings (days.py) and steps (the ledger) share one rule: an instant on a boundary ends its day."""
    ledger = DayLedger(day_us=2_880_000_000)  # theta 30
    at = np.array([0, 1, 2_880_000_000, 2_880_000_001, 5_760_000_000], np.int64)
    assert ledger.days_of(at).tolist() == [ledger.day_of(int(t)) for t in at] == [0, 0, 0, 1, 1]


def test_a_ledger_with_steps_longer_than_a_day_leaves_no_day_out() -> None:
    ledger = DayLedger(day_us=1_000_000)
    ledger.add(3_000_000, active=2, alive=4, newly_depleted=1)  # a 3-s step over three 1-s days
    assert ledger.steps == [0, 0, 1] and ledger.alive_end == [4, 4, 4] and ledger.depleted_new == [0, 0, 1]


def test_energy_per_day_is_the_difference_of_the_counters_at_each_day_end() -> None:
    record = ApadRecord((1, 2), start_us=0)
    for wh in (2.0, 5.0, 5.5):  # counters at the ends of days 1..3, both aPads alike, every counter
        record.day_energy.append(np.full((2, 3), wh))
    per_day = record.energy_per_day(np.full((2, 3), 9.0), days=4)  # day 4 ends with the mission, at 9 Wh
    np.testing.assert_allclose(per_day[:, 0, 0], [2.0, 3.0, 0.5, 3.5])
    assert per_day.shape == (4, 2, 3)
    # A mission that ended exactly on a boundary has no fifth day; a restored console's lost days are unknown.
    assert record.energy_per_day(np.full((2, 3), 5.5), days=3).shape[0] == 3
    restored = ApadRecord((1,), start_us=0, complete=False)
    restored.day_energy += [np.full((1, 3), np.nan), np.full((1, 3), 4.0)]
    assert np.isnan(restored.energy_per_day(np.full((1, 3), 6.0), days=3)[:2, 0, 0]).all()
    assert restored.energy_per_day(np.full((1, 3), 6.0), days=3)[2, 0, 0] == 2.0
