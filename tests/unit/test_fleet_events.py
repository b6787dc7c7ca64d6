"""The fleet on the event platform: long steps equal many short ones, `next_change` is exact, and a runner
stepping only where something changes gives lockstep's figures (drift 0) in far fewer steps."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from apad_sitl.vocabulary import Latch
from mavlink_dialect import Codec, mavlink
from missiontime import US_PER_S, VirtualClock
from mussel_sim.behaviour import HOURLY_WAKE
from mussel_sim.comms import FLEET_COMPONENT_ID, FLEET_SYSTEM_ID, FleetRunner
from mussel_sim.day_ledger import day_us
from mussel_sim.fleet import step
from mussel_sim.fleet_state import NO_INPUTS, FleetInputs, FleetParams, FleetState, state_from_arrays
from mussel_sim.geo import LocalFrame
from mussel_sim.next_change import first_change_step, next_change_s
from mussel_sim.recorder import Recorder
from mussel_sim.vocabulary import MusselCommand, MusselState

FRAME = LocalFrame(43.94, 15.44)
APAD, GCS = 1, 255
STILL = FleetParams(drift_half_width_m=0.0)
SLEEPY = FleetParams(drift_half_width_m=0.0, profile=HOURLY_WAKE)
apad_codec, gcs_codec = Codec(APAD, 1), Codec(GCS, 190)
RNG = np.random.default_rng(0)


def fleet(u: list[float], params: FleetParams = STILL) -> FleetState:
    n = len(u)
    return state_from_arrays(list(range(3, 3 + n)), np.linspace(0, 30, n), np.zeros(n), u, params)


def singles(state: FleetState, params: FleetParams, k: int, inputs: FleetInputs = NO_INPUTS) -> FleetState:
    for j in range(k):
        state, _ = step(state, inputs if j == 0 else NO_INPUTS, params, RNG, 1.0)
    return state


def at_once(state: FleetState, params: FleetParams, k: int, inputs: FleetInputs = NO_INPUTS) -> FleetState:
    return step(state, inputs, params, RNG, float(k), 1.0)[0]


def assert_same_course(a: FleetState, b: FleetState) -> None:
    assert a.time_us == b.time_us
    np.testing.assert_array_equal(a.state, b.state)
    np.testing.assert_allclose(a.battery_frac, b.battery_frac, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.timer_s, b.timer_s, atol=1e-9)
    np.testing.assert_allclose(a.depth_m, b.depth_m, atol=1e-9)
    np.testing.assert_array_equal(a.samples_taken, b.samples_taken)
    np.testing.assert_array_equal(a.samples_due, b.samples_due)
    np.testing.assert_array_equal(a.next_wake_sim_s, b.next_wake_sim_s)


def docked(state: FleetState, rows: list[int], params: FleetParams = STILL) -> FleetState:
    ids = [int(state.ids[r]) for r in rows]
    inputs = FleetInputs.make(apads={APAD: (0.0, 0.0)}, dock=[(m, APAD, s + 1) for s, m in enumerate(ids)])
    return step(state, inputs, params, RNG, 1.0)[0]


# --- the model: k periods at once ------------------------------------------------------------------


def test_a_long_step_equals_its_periods_up_to_each_change() -> None:
    cases: list[tuple[FleetState, FleetParams]] = [
        (fleet([0.9, 0.31, 0.02]), STILL),  # discharge, down to the first depletion
        (docked(fleet([0.05, 0.4, 0.6, 0.99]), [0, 1, 2, 3]), STILL),  # every band of eq. (2), and full
        (singles(fleet([0.8, 0.7]), STILL, 1, FleetInputs.make(apads={APAD: (0.0, 0.0)}, surface=[3, 4])), STILL),
        (fleet([0.9, 0.5, 0.3, 0.8, 0.6]), SLEEPY),  # sleepers: wakes and samples
    ]
    for state, params in cases:
        for _ in range(6):  # change after change
            k = int(min(next_change_s(state, params), 1500))
            if k >= 2:
                assert_same_course(at_once(state, params, k), singles(state, params, k))
            state = singles(state, params, max(k, 1) + 1)


def test_sleepers_over_days_at_once_count_every_wake_and_sample() -> None:
    state = fleet([0.9, 0.5, 0.6], SLEEPY)
    k = 3 * 2880  # three simulated days at theta 30
    assert next_change_s(state, SLEEPY) > k
    long, short = at_once(state, SLEEPY, k), singles(state, SLEEPY, k)
    assert_same_course(long, short)
    assert (long.samples_due >= 71).all() and (long.samples_taken == long.samples_due).all()


def test_a_long_steps_drift_is_its_periods_draw_for_draw_and_one_period_is_lockstep() -> None:
    params = FleetParams()
    state = fleet([0.9] * 2000, params)
    one = step(state, NO_INPUTS, params, np.random.default_rng(7), 1.0, 1.0)[0]
    lock = step(state, NO_INPUTS, params, np.random.default_rng(7), 1.0)[0]
    assert one.x_m.tobytes() == lock.x_m.tobytes()
    for k in (2, 100, 2500):  # 2500: more than one block of draws (`drift.DRIFT_BLOCK_STEPS`)
        rng_long, rng_many = np.random.default_rng(7), np.random.default_rng(7)
        long = step(state, NO_INPUTS, params, rng_long, float(k), 1.0)[0]
        many = state
        for _ in range(k):
            many = step(many, NO_INPUTS, params, rng_many, 1.0)[0]
        np.testing.assert_allclose(long.x_m, many.x_m, rtol=0.0, atol=1e-9)
        np.testing.assert_allclose(long.y_m, many.y_m, rtol=0.0, atol=1e-9)
        assert not np.allclose(long.x_m, state.x_m, rtol=0.0, atol=1e-4)  # it did drift
        assert rng_long.bit_generator.state == rng_many.bit_generator.state  # and left the stream where they do


# --- next_change: exact ---------------------------------------------------------------------------------


@pytest.mark.parametrize("make", [
    lambda: fleet([0.0371]),  # depletion
    lambda: singles(fleet([0.8]), STILL, 1, FleetInputs.make(apads={APAD: (0.0, 0.0)}, surface=[3])),  # timer
    lambda: docked(fleet([0.1234]), [0]),  # the first band's end
    lambda: docked(fleet([0.5]), [0]),  # the second's
    lambda: docked(fleet([0.987]), [0]),  # full
])
def test_next_change_holds_nothing_discontinuous_and_the_next_step_does(make: Callable[[], FleetState]) -> None:
    state = make()
    k = int(next_change_s(state, STILL))
    assert 2 <= k < 10_000
    course = [state]
    for _ in range(k + 1):
        course.append(singles(course[-1], STILL, 1))
    rates = np.diff([c.battery_frac[0] for c in course])
    np.testing.assert_allclose(rates[:k], rates[0], rtol=1e-9)  # up to it: one straight course
    assert all(np.array_equal(c.state, state.state) for c in course[: k + 1])
    assert 0.0 < course[k].battery_frac[0] < 1.0
    past = course[k + 1]  # one step past it: another state, a clamp or another band's rate
    ends = not np.array_equal(past.state, state.state) or past.battery_frac[0] in (0.0, 1.0)
    assert ends or not np.isclose(rates[k], rates[0], rtol=1e-9)
    if ends:  # taken alone, as lockstep takes it (a band's first step may start a long one)
        assert first_change_step(course[k], STILL, 1.0) == 1.0


# --- the runner: event steps against lockstep ----------------------------------------------------------


def apad_position(x_m: float, y_m: float) -> bytes:
    lat, lon = FRAME.to_geodetic(x_m, y_m)
    return apad_codec.encode(mavlink.MAVLink_global_position_int_message(
        0, round(float(lat) * 1e7), round(float(lon) * 1e7), 0, 0, 0, 0, 0, 0))


def slot(slot_no: int, mussel_id: int, latch: Latch) -> bytes:
    return apad_codec.encode(mavlink.MAVLink_dock_slot_status_message(
        0, slot_no, mussel_id, int(latch), int(latch == Latch.LATCHED)))


def command(mussel_id: int, cmd: MusselCommand) -> bytes:
    return gcs_codec.encode(mavlink.MAVLink_amussel_command_message(APAD, mussel_id, int(cmd)))


Script = list[tuple[float, bytes]]  # (mission s, bytes the fleet receives then)


class Run:
    """A runner on a real Scheduler and VirtualClock over `duration_s`, fed the script's bytes."""

    def __init__(self, u: list[float], params: FleetParams, events: bool, duration_s: float,
                 script: Script | None = None) -> None:
        state = state_from_arrays(list(range(3, 3 + len(u))), np.linspace(0, 40, len(u)), np.zeros(len(u)), u,
                                  params)
        self.clock = VirtualClock()
        self.statuses: list[tuple[int, int, int, float]] = []  # (time_us, id, state, battery)
        self.runner = FleetRunner(
            state, params, np.random.default_rng(1), FRAME, Codec(FLEET_SYSTEM_ID, FLEET_COMPONENT_ID),
            lambda data: None, recorder=Recorder(state.ids, day_us=day_us(params.theta),
                                                 max_trace_rows=256 if events else 1 << 16),
            local_batch=self._batch)
        end_us = round(duration_s * US_PER_S)
        self.runner.register(self.clock.scheduler, 0, end_us=end_us, events=events)
        decoder = Codec(GCS, 191)
        for t_s, data in sorted(script or [], key=lambda x: x[0]):
            self.clock.advance_to(round(t_s * US_PER_S))
            for msg in decoder.decode(data):
                self.runner.handle(msg)
        self.clock.advance_to(end_us + 2 * US_PER_S)

    def _batch(self, msg_id: int, frames: list[bytes], columns: dict[str, object]) -> None:
        if msg_id == mavlink.MAVLINK_MSG_ID_AMUSSEL_STATUS:
            ids = np.atleast_1d(np.asarray(columns["mussel_id"]))
            st = np.atleast_1d(np.asarray(columns["state"]))
            u = np.atleast_1d(np.asarray(columns["battery"]))
            for i, s, b in zip(ids, st, u, strict=True):
                self.statuses.append((int(np.asarray(columns["time_us"])), int(i), int(s), float(b)))


def assert_same_figures(lock: Run, ev: Run) -> None:
    a, b = lock.runner.recorder, ev.runner.recorder
    assert a.n_steps == b.n_steps
    np.testing.assert_allclose(a.uptime_pct(), b.uptime_pct(), atol=1e-9)
    np.testing.assert_array_equal(a.times.state_us, b.times.state_us)
    np.testing.assert_array_equal(a.times.first_depleted_us, b.times.first_depleted_us)
    np.testing.assert_array_equal(a.samples_taken, b.samples_taken)
    np.testing.assert_array_equal(a.samples_due, b.samples_due)
    assert a.days is not None and b.days is not None
    assert (a.days.steps, a.days.active_sum, a.days.alive_end, a.days.depleted_new, a.days.end_us) == (
        b.days.steps, b.days.active_sum, b.days.alive_end, b.days.depleted_new, b.days.end_us)
    assert a.summary().avg_active == pytest.approx(b.summary().avg_active, abs=1e-9)
    sa, sb = lock.runner.state, ev.runner.state
    np.testing.assert_array_equal(sa.state, sb.state)
    np.testing.assert_allclose(sa.battery_frac, sb.battery_frac, atol=1e-9)
    # The traces: bounded, evenly sampled on the step grid, at each row's instant the battery lockstep had.
    rows, battery = b.battery_trace()
    t_us = b.step_time_us()[rows]
    assert 16 < len(rows) <= b.max_trace_rows and np.unique(np.diff(t_us)).size == 1
    lock_rows, lock_battery = a.battery_trace()  # lockstep's keeps every step (`Run`)
    at = np.searchsorted(a.step_time_us()[lock_rows], t_us)
    np.testing.assert_allclose(battery, lock_battery[at], atol=1e-6)
    np.testing.assert_array_equal(b.state_trace()[1], a.state_trace()[1][at])


def changes(run: Run) -> list[tuple[int, int, int]]:
    """Each aMussel's reported state changes: (time_us, id, state), in order."""
    last: dict[int, int] = {}
    out = []
    for t, i, s, _ in run.statuses:
        if last.get(i) != s:
            out.append((t, i, s))
            last[i] = s
    return out


def both(u: list[float], params: FleetParams, duration_s: float, script: Script | None = None) -> tuple[Run, Run]:
    return Run(u, params, False, duration_s, script), Run(u, params, True, duration_s, script)


def test_a_fleet_left_alone_runs_flat_as_in_lockstep_in_a_few_steps() -> None:
    lock, ev = both([0.9, 0.2, 0.05, 0.5], STILL, 3 * 2880.0)
    assert_same_figures(lock, ev)
    assert (ev.runner.recorder.times.first_depleted_us > 0).all()
    assert ev.runner.event_steps is not None and ev.runner.event_steps.steps < 30
    assert changes(lock) == changes(ev)


def test_a_dock_and_release_charges_through_every_band_as_in_lockstep() -> None:
    script: Script = [(10.0, apad_position(0.0, 0.0)), (10.0, command(4, MusselCommand.SURFACE)),
                      (40.5, slot(1, 4, Latch.CLOSING)), (41.0, slot(1, 4, Latch.LATCHED)),
                      (2500.25, slot(1, 4, Latch.RELEASING)), (2501.0, slot(1, 0, Latch.OPEN))]
    script += [(t, apad_position(0.0, 0.0)) for t in np.arange(50.0, 1200.0, 1.0)]  # the aPad says it stays
    script += [(1200.5, apad_position(6.0, 8.0))]  # and moves, its docked aMussel with it
    lock, ev = both([0.9, 0.1, 0.7], STILL, 3000.0, script)
    assert_same_figures(lock, ev)
    assert (ev.runner.state.x_m[1], ev.runner.state.y_m[1]) == pytest.approx((6.0, 8.0), abs=0.01)
    np.testing.assert_array_equal(ev.runner.state.x_m, lock.runner.state.x_m)
    assert lock.runner.recorder.times.state_us[1, MusselState.DOCKED] == 2460 * US_PER_S
    assert ev.runner.event_steps is not None and ev.runner.event_steps.steps < 40
    assert changes(lock) == changes(ev)
    # The release's status (what the charger meters by) shows the same battery on both.
    released = [s for s in lock.statuses if s[0] == 2500 * US_PER_S and s[1] == 4]
    assert released and [s for s in ev.statuses if s[0] == 2500 * US_PER_S and s[1] == 4] == pytest.approx(released)


def test_a_sleeping_fleet_over_days_and_a_held_call_up_as_in_lockstep() -> None:
    script: Script = [(30.0, apad_position(0.0, 0.0)), (1000.4, command(3, MusselCommand.SURFACE)),
                      (1000.4, command(4, MusselCommand.SURFACE))]
    lock, ev = both([0.9, 0.5, 0.02, 0.6], SLEEPY, 3 * 2880.0, script)
    assert_same_figures(lock, ev)
    assert lock.runner.recorder.samples_due.min() > 65
    assert ev.runner.event_steps is not None and ev.runner.event_steps.steps < 60
    assert changes(lock) == changes(ev)


def test_a_command_mid_span_is_taken_at_the_next_step_instant() -> None:
    script: Script = [(5.0, apad_position(0.0, 0.0)), (733.7, command(3, MusselCommand.SURFACE))]
    lock, ev = both([0.9], STILL, 900.0, script)
    assert_same_figures(lock, ev)
    surfacing = [c for c in changes(ev) if c[2] == MusselState.SURFACING]
    assert surfacing == [(734 * US_PER_S, 3, MusselState.SURFACING)]
    assert changes(lock) == changes(ev)


def test_a_part_reading_the_fleet_between_its_steps_sees_lockstep_s_model() -> None:
    lock = Run([0.9, 0.5], STILL, False, 600.0)
    state = state_from_arrays([3, 4], [0.0, 40.0], [0.0, 0.0], [0.9, 0.5], STILL)
    clock = VirtualClock()
    runner = FleetRunner(state, STILL, np.random.default_rng(1), FRAME, Codec(FLEET_SYSTEM_ID, FLEET_COMPONENT_ID),
                         lambda data: None)
    runner.register(clock.scheduler, 0, end_us=600 * US_PER_S, events=True)
    clock.advance_to(417_500_000)
    assert runner.state.time_us == 0  # nothing changed: no step yet
    runner.bring_up_to(417_500_000)  # as the acoustic modems do at their slots
    assert runner.state.time_us == 417 * US_PER_S
    _, lock_u = lock.runner.recorder.battery_trace()
    np.testing.assert_allclose(runner.state.battery_frac, lock_u[416], atol=1e-6)  # float32 traces
    clock.advance_to(600 * US_PER_S)
    assert runner.recorder.n_steps == 600


def test_an_event_recorder_restores_from_its_head_and_rows() -> None:
    ev = Run([0.9, 0.2, 0.6], SLEEPY, True, 3 * 2880.0)
    rec = ev.runner.recorder
    assert rec.n_rows < rec.n_steps
    again = Recorder.restore(rec.head(), rec.rows_since(0))
    assert (again.n_steps, again.n_rows) == (rec.n_steps, rec.n_rows)
    for a, b in ((again.battery_trace(), rec.battery_trace()), (again.state_trace(), rec.state_trace())):
        np.testing.assert_array_equal(a[0], b[0])
        np.testing.assert_array_equal(a[1], b[1])
    np.testing.assert_array_equal(again.step_time_us(), rec.step_time_us())
    np.testing.assert_allclose(again.uptime_pct(), rec.uptime_pct())
