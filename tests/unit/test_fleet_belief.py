"""The fleet-wide belief (`gcs.belief.fleet_belief`, `gcs.loop.fleet_beliefs`) against the scalar one it stands for,
bit for bit: `believed_rows` against `foreseen_battery` and `believed_battery` over drawn tables, and a real
`FleetKnowledge` over a real link's registry (a mixed fleet: deployed, docked on this aPad and on another, let go
of since the report, on a sleep order, depleted, real) against its own `battery`, at many instants; the idle
wait's `pool_look_by` against the per-aMussel formula it replaced."""

from __future__ import annotations

import random
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray
from wake_reference import same_instant, scalar_pool_look_by

from apad_sitl.vocabulary import Latch
from gcs.acoustic_net.knowledge import UNDERWATER, believed_battery
from gcs.belief.duty import Duty
from gcs.belief.fleet_belief import NO_ANCHOR_US, Anchors, believed_rows
from gcs.belief.foresight import MODEL_STEP_US, foreseen_battery
from gcs.belief.real_fleet import RealFleet
from gcs.link.apad_api import ApadApi, Location
from gcs.link.router import Link
from gcs.link.telemetry import Heartbeat, MusselView, SlotView
from gcs.loop import fleet_beliefs
from gcs.loop.book import LoopBook
from gcs.loop.control import LoopLog
from gcs.loop.fleet_knowledge import FleetKnowledge
from gcs.loop.wake_times import pool_look_by
from gcs.mission.world import loop_settings
from gcs.records.events import EventLog
from gcs.scenario.reader import load_scenario
from missiontime import US_PER_S, VirtualClock
from mussel_sim.battery import charge_profile, discharge_profile
from mussel_sim.vocabulary import MusselState

THETA = 30.0
CHARGE = charge_profile("secondary")
EVERY_STATE = tuple(MusselState)


def bits(values: NDArray[np.float64] | list[float]) -> list[str]:
    """Each float as its exact hex: equal lists are equal to the bit (0.0 and -0.0 apart)."""
    return [float(v).hex() for v in values]


# --- the pure rows -----------------------------------------------------------------------------------------

row = st.tuples(
    st.sampled_from(EVERY_STATE), st.booleans(),
    st.one_of(st.floats(0.0, 1.0), st.sampled_from([0.0, 1e-9, 0.25, 0.8, 1.0])),  # battery reported
    st.integers(0, 50_000_000_000),  # report, mission us
    st.one_of(st.just(0.0), st.floats(1e-7, 1e-3)),  # drain per s (0: never drains)
    st.one_of(st.none(), st.tuples(st.integers(0, 50_000_000_000), st.floats(0.0, 1.0))),  # a sleep order's anchor
)


@settings(max_examples=300, deadline=None)
@given(rows=st.lists(row, min_size=1, max_size=30), now_us=st.integers(0, 60_000_000_000),
       acoustic=st.booleans())
def test_every_exact_row_is_the_scalar_belief_to_the_bit(rows: list[tuple[MusselState, bool, float, int, float,
                                                                          tuple[int, float] | None]],
                                                         now_us: int, acoustic: bool) -> None:
    state = np.array([r[0] for r in rows], np.uint8)
    simulated = np.array([r[1] for r in rows], bool)
    frac = np.array([r[2] for r in rows], np.float64)
    time_us = np.array([r[3] for r in rows], np.int64)
    drain = np.array([r[4] for r in rows], np.float64)
    changed = {k: r[5] for k, r in enumerate(rows) if r[5] is not None}
    anchors = Anchors.of(range(len(rows)), changed)
    belief, exact = believed_rows(frac, time_us, state, simulated, now_us, drain, anchors, acoustic)
    for k, (s, sim, battery, report_us, per_s, anchor) in enumerate(rows):
        assert exact[k] == (sim and s != MusselState.DOCKED)  # a docked or a real one: the scalar's
        if not exact[k]:
            continue
        view = MusselView(k + 1, 0, 0, 0.0, battery, 4000, s, sim, report_us)
        if acoustic and s in UNDERWATER:
            want = believed_battery(view, now_us, per_s, anchor)
        else:
            want = foreseen_battery(view, now_us, per_s, CHARGE, THETA, None, anchor)
        assert bits([belief[k]]) == bits([want]), (k, rows[k])


@pytest.mark.parametrize("acoustic", [False, True])
def test_thousands_of_rows_run_down_part_way_are_the_scalar_to_the_bit(acoustic: bool) -> None:
    """Reports old enough to have used a part of what they held (where a float's last bit shows): every state,
    anchors before and after the report."""
    rng = np.random.default_rng(3)
    n, now_us = 4000, 90_000 * US_PER_S
    frac, drain = rng.random(n), rng.uniform(1e-6, 1e-4, n)
    age_us = (1.2 * rng.random(n) * frac / drain * US_PER_S).astype(np.int64)  # up to a little past empty
    time_us = now_us - age_us
    state = rng.integers(0, len(MusselState), n).astype(np.uint8)
    simulated = rng.random(n) < 0.95
    later = rng.random(n) < 0.3
    changed = {k: (int(time_us[k] + (1 if later[k] else -1) * rng.integers(1, 10**9)), float(rng.random()))
               for k in range(n) if rng.random() < 0.5}
    belief, exact = believed_rows(frac, time_us, state, simulated, now_us, drain, Anchors.of(range(n), changed),
                                  acoustic)
    want = []
    for k in np.flatnonzero(exact).tolist():
        view = MusselView(k + 1, 0, 0, 0.0, float(frac[k]), 4000, MusselState(int(state[k])), True, int(time_us[k]))
        per_s = float(drain[k])
        want.append(believed_battery(view, now_us, per_s, changed.get(k)) if acoustic and view.state in UNDERWATER
                    else foreseen_battery(view, now_us, per_s, CHARGE, THETA, None, changed.get(k)))
    assert bits(belief[exact]) == bits(want)
    assert 0 < int((belief[exact] > 0).sum()) < exact.sum()  # some run flat, most part way


def test_a_row_reported_within_its_step_stands_and_one_run_flat_holds_at_zero() -> None:
    state = np.array([MusselState.ACTIVE, MusselState.ACTIVE, MusselState.DEPLETED], np.uint8)
    none = Anchors.of(range(3), {})
    belief, exact = believed_rows(np.array([0.5, 0.001, 0.3]), np.array([0, 0, 0], np.int64), state,
                                  np.ones(3, bool), MODEL_STEP_US - 1, np.full(3, 0.01), none, False)
    assert belief.tolist() == [0.5, 0.001, 0.3] and exact.all()
    belief, _ = believed_rows(np.array([0.5, 0.001, 0.3]), np.array([0, 0, 0], np.int64), state,
                              np.ones(3, bool), 10 * MODEL_STEP_US, np.full(3, 0.01), none, False)
    assert bits(belief) == bits([0.5 - 10 * 0.01 * 1.0, 0.0, 0.3])


def test_an_anchor_older_than_the_report_is_not_used() -> None:
    anchors = Anchors(np.array([5 * US_PER_S, NO_ANCHOR_US], np.int64), np.array([0.9, 0.0]))
    belief, _ = believed_rows(np.array([0.5, 0.5]), np.array([10 * US_PER_S, 10 * US_PER_S], np.int64),
                              np.array([MusselState.ACTIVE] * 2, np.uint8), np.ones(2, bool), 20 * US_PER_S,
                              np.full(2, 0.001), anchors, True)
    assert belief[0] == belief[1] == 0.5 - 0.001 * 10_000_000 / US_PER_S


# --- a real knowledge over a real registry -----------------------------------------------------------------

HERE, OTHER = 1, 2
DEPLOYED = (MusselState.ACTIVE, MusselState.SURFACING, MusselState.FLOATING, MusselState.SINKING)


class Fleet:
    """A real `Link`'s registry heard from two aPads and a mixed fleet, and aPad 1's real `FleetKnowledge`."""

    def __init__(self, seed: int) -> None:
        self.rng = random.Random(seed)
        s = load_scenario("bay120-sleep")
        self.clock = VirtualClock(start_us=3_600 * US_PER_S)
        self.link = Link(self.clock, ideal=True)
        self.registry = self.link.registry
        ids = list(range(1, 41))
        settings = loop_settings(s, s.apad, ids)
        real = RealFleet(self.registry.mussels, self.registry.mussel_heard_us, discharge_profile(s.fleet.discharge),
                         charge_profile(s.fleet.charge), s.mission.theta)
        homes = {m: Location(43.9388, 15.4394) for m in ids}
        self.knows = FleetKnowledge(ApadApi(self.link, self.clock, HERE), self.clock, settings, homes, HERE, real=real)
        self.book = LoopBook(self.knows, self.knows.orders, LoopLog(EventLog(), self.clock))
        for apad in (HERE, OTHER):
            self.apply(apad, Heartbeat(0, True))
        self.report(ids, self.rng.choice)
        self.report([101, 102, 103], lambda _: MusselState.ACTIVE, simulated=False)  # real agents

    def apply(self, apad: int, record: object) -> None:
        assert self.registry.apply(apad, record, self.clock.now_us) is None  # type: ignore[arg-type]

    def report(self, ids: list[int], state: object, simulated: bool = True) -> None:
        """A report from each of `ids`, made a while ago (some run flat), in a state drawn by `state`."""
        now_us = self.clock.now_us
        for m in ids:
            s = state(EVERY_STATE)  # type: ignore[operator]
            battery = self.rng.choice([0.0, 1e-6, self.rng.random(), 0.99, 1.0]) if s != MusselState.DEPLETED else 0.0
            made_us = max(now_us - self.rng.randrange(0, 4_000 * US_PER_S), 0)
            self.apply(HERE, MusselView(m, 439_388_000, 154_394_000, 5.0, battery, 3700, s, simulated, made_us))

    def dock(self, apad: int, slot: int, mussel_id: int, simulated: bool = True) -> None:
        self.report([mussel_id], lambda _: MusselState.DOCKED, simulated)
        self.apply(apad, SlotView(slot, mussel_id, Latch.LATCHED, charging=True))

    def let_go(self, apad: int, slot: int) -> None:
        """The slot opens: the registry notes the release (charged till now), the table still says DOCKED."""
        self.apply(apad, SlotView(slot))

    def check(self) -> int:
        """Every belief at this instant, fleet-wide against the scalar; how many aMussels were compared."""
        knows = self.knows
        ids = sorted(knows.api.mussels)
        scalar = [knows.battery(m) for m in ids]
        whole = knows.believed(EVERY_STATE)
        assert whole.ids.tolist() == ids
        assert bits(whole.battery) == bits(scalar)
        assert bits(whole.drain_per_s) == bits([knows.drain_per_s(m) for m in ids])
        shuffled = self.rng.sample(ids, len(ids))
        assert bits(knows.batteries(shuffled)) == bits([knows.battery(m) for m in shuffled])
        for states in (DEPLOYED, (MusselState.ACTIVE,), (MusselState.DOCKED, MusselState.DEPLETED)):
            some = knows.believed(states)
            assert some.ids.tolist() == knows.in_states(states)
            assert bits(some.battery) == bits([knows.battery(m) for m in some.ids.tolist()])
        return len(ids)


def test_a_mixed_fleets_belief_is_the_scalar_one_to_the_bit_at_many_instants() -> None:
    f = Fleet(seed=7)
    f.dock(HERE, 1, 1)
    f.dock(HERE, 2, 2)
    f.dock(OTHER, 1, 3)  # docked on another aPad: charging on by its report
    f.dock(OTHER, 2, 4)
    f.dock(HERE, 3, 102, simulated=False)  # a real one on one of our slots
    f.clock.advance_to(f.clock.now_us + 2_500_000)
    f.let_go(HERE, 2)  # released since its report, on this aPad and on the other
    f.let_go(OTHER, 2)
    f.book.ordered(5, Duty.of_order(3600.0, 10.0))  # sleep orders: another drain from now on
    f.book.ordered(6, Duty.of_order(0.0, 0.0))
    compared = 0
    for step in range(60):
        f.clock.advance_to(f.clock.now_us + f.rng.choice([1, 999_999, 1_000_000, 1_500_000, 37_000_000]))
        if step % 7 == 3:  # news: some report again (a report from the future too), a duty changes
            f.report(f.rng.sample(range(7, 41), 5), f.rng.choice)
            f.apply(HERE, MusselView(40, 0, 0, 5.0, 0.5, 3700, MusselState.ACTIVE, True, f.clock.now_us + 2_000_000))
            f.book.ordered(f.rng.randrange(7, 41), Duty.of_order(f.rng.choice([0.0, 3600.0]), 10.0))
        compared += f.check()
    assert compared == 60 * 43


def test_the_idle_waits_look_by_is_the_per_amussel_formulas() -> None:
    f = Fleet(seed=11)
    seen = set()
    for _ in range(40):
        f.clock.advance_to(f.clock.now_us + f.rng.choice([1_000_000, 20_000_000, 300_000_000]))
        f.report(f.rng.sample(range(1, 41), 8), lambda _: f.rng.choice([MusselState.ACTIVE, MusselState.ACTIVE,
                                                                         MusselState.FLOATING]))
        got = pool_look_by(f.knows)
        assert same_instant(got, scalar_pool_look_by(f.knows))
        seen.add(got is None)
    assert seen == {False}  # always some aMussel to wait for


def test_the_rows_are_made_once_per_table_version_and_instant(monkeypatch: pytest.MonkeyPatch) -> None:
    made: list[int] = []

    def counted(*args: Any) -> Any:
        made.append(1)
        return believed_rows(*args)

    monkeypatch.setattr(fleet_beliefs, "believed_rows", counted)
    f = Fleet(seed=5)
    for _ in range(5):  # the idle wait's reads at one instant: the pool, its wake time, a schedule's batteries
        f.knows.pool()
        pool_look_by(f.knows)
        f.knows.batteries([1, 2, 3])
    assert len(made) == 1
    f.clock.advance_to(f.clock.now_us + 1)  # time moved on
    f.knows.pool()
    f.report([7], lambda _: MusselState.ACTIVE)  # a report
    f.knows.pool()
    f.book.ordered(8, Duty.of_order(3600.0, 10.0))  # a sleep order: another drain
    f.knows.pool()
    assert len(made) == 4


def test_an_id_never_heard_is_a_key_error() -> None:
    f = Fleet(seed=3)
    try:
        f.knows.batteries([1, 999])
    except KeyError as exc:
        assert exc.args == (999,)
    else:
        raise AssertionError("an id never heard has no belief")
