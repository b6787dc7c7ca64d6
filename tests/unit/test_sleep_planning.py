"""Planning with each aMussel's own behaviour (issue 20): its drain (profile or sleep order) and when a
sleeper can hear a call-up; and keep_alive's sleep scheduler, on small hand-built fleets."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from gcs.belief.duty import Duty
from gcs.strategies import Outlook, PlanInput, ScheduleInput, plan
from gcs.strategies.keep_alive import keep_alive_schedule, leg_s
from gcs.strategies.lookahead import dock_times_s
from gcs.strategies.urgency import slack_s, time_to_depletion_s
from mussel_sim.behaviour import duty_cycle_rate_per_min
from mussel_sim.geo import LocalFrame
from mussel_sim.wake import next_wake_s

FRAME = LocalFrame(43.94, 15.44)
DAY = Outlook(time_left_s=86400.0)
ON = DAY.drain_per_s  # always on, eq. (1): a full battery lasts 1918 mission s at theta 30
HOURLY = duty_cycle_rate_per_min(3600.0, 10.0) * 30.0 / 60.0  # Table I's hourly wake, per mission s


def fleet(xy_m: list[tuple[float, float]], battery: list[float], drain: list[float] | None = None,
          wake: list[float] | None = None) -> PlanInput:
    x, y = np.array(xy_m, float).T
    lat, lon = FRAME.to_geodetic(x, y)
    alat, alon = FRAME.to_geodetic(0.0, 0.0)
    return PlanInput({1: (float(alat), float(alon))}, {1: 4}, np.arange(1, len(xy_m) + 1), lat, lon,
                     np.array(battery, float), DAY, None if drain is None else np.array(drain, float),
                     None if wake is None else np.array(wake, float))


def test_each_candidate_depletes_at_its_own_rate() -> None:
    inp = fleet([(5, 0), (10, 0)], [0.3, 0.3], drain=[ON, HOURLY])
    ttd = time_to_depletion_s(inp)
    assert ttd[0] == pytest.approx(0.3 / ON)
    assert ttd[1] == pytest.approx(0.3 / HOURLY) and ttd[1] > 14 * ttd[0]  # Table I: 14,057 vs 962 min
    assert np.array_equal(time_to_depletion_s(replace(inp, drain_per_s=None)), 0.3 / np.full(2, ON))


def test_a_sleeper_with_less_charge_waits_for_an_always_on_one_with_more() -> None:
    """Lowest battery is not most urgent: the sleeper at 0.2 lasts hours, the always-on one at 0.4 minutes."""
    inp = fleet([(5, 0), (6, 0)], [0.2, 0.4], drain=[HOURLY, ON])
    assert plan("least_slack", inp)[1][0] == 2
    hour = replace(inp, outlook=replace(DAY, time_left_s=3600.0))  # the sleeper lasts to the end, 5,623 s
    assert plan("keep_alive", hour)[1] == [2] and plan("least_slack", hour)[1] == [2]
    assert plan("cautious", inp)[1][0] == 1  # the paper's: lowest battery first, whatever it does


def test_a_route_does_not_wait_on_a_sleeper_while_another_depletes() -> None:
    """Two equally low always-on aMussels 2 m apart, the nearer asleep for another 110 s: taken first, it
    would hold the route until it wakes and the other would empty meanwhile; the awake one goes first."""
    inp = fleet([(10, 0), (10, 2)], [0.1, 0.1], drain=[ON, ON], wake=[110.0, 0.0])  # 192 s left each
    slack = slack_s(inp, *inp.apads[1])
    assert slack[0] == pytest.approx(slack[1] - (110.0 - 10 / DAY.speed_mps), abs=0.5)
    assert plan("keep_alive", inp)[1] == [2, 1]
    assert plan("lookahead", inp)[1][0] == 2
    assert plan("keep_alive", replace(inp, wake_in_s=None))[1] == [1, 2]  # both awake: the nearer first


def test_lookahead_docks_a_sleeper_only_once_it_woke() -> None:
    legs = np.array([[10.0, 10.0]])  # metres: 20 s each at 0.5 m/s
    woke = dock_times_s(DAY, legs, np.array([[100.0, 0.0]]))
    awake = dock_times_s(DAY, legs, np.array([[0.0, 0.0]]))
    assert awake.tolist() == [[20 + DAY.stop_s, 40 + 2 * DAY.stop_s]]
    assert woke.tolist() == [[100 + DAY.stop_s, 120 + 2 * DAY.stop_s]]


def test_a_duty_is_the_fleets_model_of_its_profile_or_order() -> None:
    order = Duty.of_order(3600.0, 10.0)
    assert order.asleep and order.ordered and order.drain_per_s(30.0) == pytest.approx(HOURLY)
    assert not Duty.of_order(0.0, 0.0).asleep
    t = 1234.5
    assert order.wake_in_s(7, t, 30.0) == pytest.approx(next_wake_s(7, 3600.0, 10.0, t, 30.0) - t)
    assert 0.0 <= order.wake_in_s(7, t, 30.0) <= order.longest_wait_s(30.0) == 120.0
    assert Duty(ON * 60 / 30).wake_in_s(7, t, 30.0) == 0.0


def schedule(battery: list[float], asleep: list[bool] | None = None, start_s: float = 0.0,
             orderable: list[bool] | None = None) -> dict[int, bool]:
    n = len(battery)
    x = np.arange(n) * 5.0
    lat, lon = FRAME.to_geodetic(x, np.zeros(n))
    sleeping = np.array(asleep or [False] * n)
    drain = np.where(sleeping, HOURLY, ON)
    return keep_alive_schedule(ScheduleInput(
        np.arange(1, n + 1), lat, lon, np.array(battery, float), drain, np.full(n, ON), sleeping,
        np.array(orderable or [True] * n), 4, start_s, DAY))


def test_keep_alive_lets_a_fleet_the_slots_can_serve_stay_always_on() -> None:
    assert schedule([0.5, 0.6, 0.7, 0.9]) == {}


def test_keep_alive_puts_to_sleep_those_the_queue_cannot_reach_in_time() -> None:
    """Twelve always-on aMussels, four slots: a round (fetch, charge, return) outlasts the fullest ones'
    charge, so those the second and third rounds would reach too late sleep; the first round's do not."""
    battery = [0.3, 0.35, 0.4, 0.45, 0.6, 0.65, 0.7, 0.75, 0.8, 0.85, 0.9, 0.95]
    orders = schedule(battery)
    assert orders and not any(orders.values())  # only sleep orders
    assert not {1, 2, 3, 4} & set(orders)  # the first round reaches these in time
    ttd = np.array(battery) / ON
    n = len(battery)
    for m in orders:
        assert ttd[m - 1] < 2 * 86400.0
    assert len(orders) <= n - 4


def test_keep_alive_puts_every_always_on_one_to_sleep_before_a_home_charge() -> None:
    orders = schedule([0.5, 0.9, 0.99], start_s=np.inf)
    assert orders == {1: False, 2: False, 3: False}
    assert schedule([0.5, 0.9], asleep=[True, True], start_s=np.inf) == {}  # asleep already
    assert schedule([0.5, 0.9], start_s=np.inf, orderable=[False, True]) == {2: False}  # its own profile sleeps


def test_keep_alive_wakes_a_charged_sleeper_when_the_queue_allows() -> None:
    assert schedule([0.95, 0.6], asleep=[True, False]) == {1: True}
    assert schedule([0.3, 0.6], asleep=[True, False]) == {}  # too low: it sleeps on until charged
    assert schedule([0.75, 0.6], asleep=[True, False]) == {1: True}  # after a home charge: back to work
    assert leg_s(replace_slots(4)) > 0


def replace_slots(slots: int) -> ScheduleInput:
    lat, lon = FRAME.to_geodetic(np.array([0.0, 10.0]), np.zeros(2))
    return ScheduleInput(np.array([1, 2]), lat, lon, np.array([0.5, 0.5]), np.full(2, ON), np.full(2, ON),
                         np.zeros(2, bool), np.ones(2, bool), slots, 0.0, DAY)
