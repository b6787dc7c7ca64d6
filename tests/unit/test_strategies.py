"""The strategies beyond the paper on hand-built layouts where the right answer is known."""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np
import pytest

from gcs.strategies import COLLECT, STRATEGIES, CostWeights, Outlook, PlanInput, plan, route_length_m, routing, traits
from gcs.strategies.routing import best_route, metres_matrix
from mussel_sim.battery import charge_profile, discharge_profile, step_battery
from mussel_sim.geo import LocalFrame

FRAME = LocalFrame(43.94, 15.44)
PAPER = Outlook()  # theta 30: a full battery lasts 1918 s of mission time
DRAIN = PAPER.drain_per_s


def layout(xy_m: list[tuple[float, float]], battery: list[float], capacity: int = 4,
           outlook: Outlook = PAPER) -> PlanInput:
    x, y = np.array(xy_m, float).T
    lat, lon = FRAME.to_geodetic(x, y)
    alat, alon = FRAME.to_geodetic(0.0, 0.0)
    return PlanInput({1: (float(alat), float(alon))}, {1: capacity}, np.arange(1, len(xy_m) + 1),
                     lat, lon, np.array(battery, float), outlook)


def length(inp: PlanInput, route: list[int]) -> float:
    stops = [(float(inp.lat_deg[m - 1]), float(inp.lon_deg[m - 1])) for m in route]
    return route_length_m(inp.apads[1], stops)


def test_every_strategy_is_registered_under_its_name() -> None:
    assert set(STRATEGIES) == set(COLLECT)
    assert traits("rolling").rolling and not traits("cautious").rolling
    assert not traits("cautious").release_early and traits("least_slack").release_early


def test_the_charging_model_times_the_fleet_model() -> None:
    """Outlook.charge_time_s (planning) against mussel_sim's battery stepping (the simulated fleet)."""
    u, steps = np.array([0.1]), 0
    while u[0] < PAPER.charged_frac:
        u = step_battery(u, np.array([True]), discharge_profile("active"), charge_profile("secondary"),
                         PAPER.theta, 1.0)
        steps += 1
    assert PAPER.charge_time_s(0.1) == pytest.approx(steps, abs=1.5)
    assert PAPER.charge_time_s(0.995) == 0.0


def test_least_slack_takes_the_one_about_to_deplete_even_far_away() -> None:
    # A near aMussel with half a battery, a far one (60 m, 2 min away) with minutes left.
    inp = layout([(5, 0), (60, 0)], [0.5, 0.12], capacity=1, outlook=replace(PAPER, time_left_s=2000.0))
    assert plan("least_slack", inp) == {1: [2]}
    assert plan("greedy", inp) == {1: [1]}


def test_least_slack_leaves_those_that_last_to_the_end() -> None:
    # 600 s left: 0.5 lasts 959 s, 0.2 lasts 384 s.
    inp = layout([(5, 0), (10, 0)], [0.5, 0.2], outlook=replace(PAPER, time_left_s=600.0))
    assert plan("least_slack", inp) == {1: [2]}
    assert plan("rolling", inp) == {1: [2]}
    assert plan("route_optimal", inp) == {1: [2]}
    assert plan("lookahead", inp) == {1: [2]}
    late = layout([(5, 0)], [0.5], outlook=replace(PAPER, time_left_s=300.0))
    for name in ("least_slack", "rolling", "route_optimal", "lookahead"):
        assert plan(name, late) == {1: []}, name


def test_route_optimal_beats_nearest_next_on_the_same_load() -> None:
    # On a line: nearest next goes 1 m east, 3 m back west, 9 m on west, then 21 m east (34 m).
    # Finishing the east first and sweeping west once is 31 m.
    inp = layout([(1, 0), (-2, 0), (10, 0), (-11, 0)], [0.3] * 4)
    greedy, best = plan("greedy", inp)[1], plan("route_optimal", inp)[1]
    assert sorted(best) == sorted(greedy) == [1, 2, 3, 4]
    assert length(inp, greedy) == pytest.approx(34.0, abs=0.1)
    assert length(inp, best) == pytest.approx(31.0, abs=0.1)


@pytest.mark.parametrize("seed", range(3))
def test_the_route_is_exact_against_every_ordered_load(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n, capacity = 7, 3
    x, y = rng.uniform(-30, 30, n), rng.uniform(-25, 25, n)
    lat, lon = FRAME.to_geodetic(x, y)
    prize = rng.uniform(0, 60, n)
    start = (43.94, 15.44)
    metres = metres_matrix(np.concatenate(([start[0]], lat)), np.concatenate(([start[1]], lon)))

    def cost(route: tuple[int, ...]) -> float:
        stops = [0, *(k + 1 for k in route)]
        return float(sum(metres[a, b] for a, b in itertools.pairwise(stops)) + prize.sum() - prize[list(route)].sum())

    best = min(cost(r) for k in range(capacity + 1) for r in itertools.permutations(range(n), k))
    assert cost(tuple(best_route(start, lat, lon, prize, capacity))) == pytest.approx(best, abs=0.02)


def test_a_pool_past_the_exact_models_size_is_cut_to_its_likeliest_gains() -> None:
    """100 candidates (stress240's pools): the route is the exact one over the `MAX_CANDIDATES` that could gain
    the most (a prize less the shortest leg into it), which keep the near, valuable ones and drop the far,
    cheap ones; a pool within the size is solved whole."""
    rng = np.random.default_rng(7)
    n = 100
    x, y = rng.uniform(-60, 60, n), rng.uniform(-60, 60, n)
    lat, lon = FRAME.to_geodetic(x, y)
    prize = rng.uniform(1, 200, n)
    prize[0], x[0], y[0] = 200.0, 1.0, 1.0  # the best of all, beside the aPad
    prize[1], x[1], y[1] = 1.0, 59.0, 59.0  # nearly worthless, in a far corner
    lat, lon = FRAME.to_geodetic(x, y)
    start = (43.94, 15.44)
    kept = routing.likeliest(start, lat, lon, prize, np.arange(n))
    assert len(kept) == routing.MAX_CANDIDATES and 0 in kept and 1 not in kept
    route = best_route(start, lat, lon, prize, 4)
    only = np.zeros(n)
    only[kept] = prize[kept]
    assert route == best_route(start, lat, lon, only, 4) and 0 in route  # the exact route over those offered
    few = np.where(np.isin(np.arange(n), kept), prize, 0.0)
    assert routing.likeliest(start, lat, lon, few, np.flatnonzero(few > 0)).tolist() == sorted(kept.tolist())


def test_the_likeliest_gain_counts_the_leg_from_the_apad_and_from_each_other_candidate(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(routing, "MAX_CANDIDATES", 2)
    # A: a small prize a metre from the aPad; B, C: larger prizes, each 60 m from everything.
    lat, lon = FRAME.to_geodetic(np.array([1.0, 0.0, 0.0]), np.array([0.0, 60.0, -60.0]))
    prize = np.array([10.0, 12.0, 11.5])
    kept = routing.likeliest((43.94, 15.44), lat, lon, prize, np.arange(3))
    assert kept.tolist() == [0, 1]  # A gains 9; B and C lose about 48: the larger prize of the two
    near = FRAME.to_geodetic(np.array([1.0, 60.0, 61.0]), np.array([0.0, 0.0, 0.0]))  # B and C a metre apart
    assert routing.likeliest((43.94, 15.44), *near, prize, np.arange(3)).tolist() == [1, 2]


def test_route_optimal_prefers_a_compact_load_among_equals() -> None:
    # Five in equal need: four close together east, one alone far west: the cluster is taken.
    inp = layout([(10, 0), (11, 2), (12, 0), (11, -2), (-25, 0)], [0.3] * 5)
    assert sorted(plan("route_optimal", inp)[1]) == [1, 2, 3, 4]


def test_lookahead_takes_the_one_that_cannot_wait_for_the_next_trip() -> None:
    # One slot. Near: 0.5 (16 min left). Far, 40 m away: 0.15 (4.8 min). Taking the near one first,
    # the far one would deplete while the near one charges.
    inp = layout([(3, 0), (40, 0)], [0.5, 0.15], capacity=1, outlook=replace(PAPER, time_left_s=2400.0))
    assert plan("lookahead", inp) == {1: [2]}


def test_lookahead_does_not_hold_a_nearly_full_one_for_an_empty_one() -> None:
    # Two slots. One nearly flat, one at 0.75, both needing a charge before the end; a third far
    # away with time to spare. Charging 0.75 beside the flat one would keep it ~8 min on the slot
    # waiting; the look-ahead sends the flat one alone, or with a partner of similar need.
    inp = layout([(5, 0), (6, 0), (30, 0)], [0.1, 0.75, 0.12], capacity=2,
                 outlook=replace(PAPER, time_left_s=2400.0))
    assert 2 not in plan("lookahead", inp)[1]


def test_weighted_differs_from_greedy_and_cautious_with_the_shipped_scales() -> None:
    from gcs.scenario.reader import load_scenario

    mission = load_scenario("pool12").mission
    weights = CostWeights(mission.distance_scale, mission.energy_scale)
    # Near 0.7, middle 0.6, far 0.2: greedy goes near first, cautious far first, weighted the middle.
    inp = layout([(3, 0), (8, 0), (25, 0)], [0.7, 0.55, 0.2], capacity=1)
    assert plan("greedy", inp)[1] == [1]
    assert plan("cautious", inp)[1] == [3]
    assert plan("weighted", inp, weights)[1] == [2]
