"""Planner strategies on hand-built layouts where the right answer is obvious."""

from __future__ import annotations

import numpy as np
import pytest

from gcs.strategies import STRATEGIES, CostWeights, PlanInput, plan, route_length_m, strategy
from mussel_sim.geo import LocalFrame

FRAME = LocalFrame(43.94, 15.44)


def layout(xy_m: list[tuple[float, float]], battery: list[float], apad_xy: tuple[float, float] = (0.0, 0.0),
           capacity: int = 4) -> PlanInput:
    x, y = np.array(xy_m, float).T
    lat, lon = FRAME.to_geodetic(x, y)
    alat, alon = FRAME.to_geodetic(*apad_xy)
    return PlanInput({1: (float(alat), float(alon))}, {1: capacity}, np.arange(1, len(xy_m) + 1),
                     lat, lon, np.array(battery, float))


# Six aMussels on a line east of the aPad; batteries highest close, lowest far.
LINE = layout([(10, 0), (20, 0), (30, 0), (40, 0), (50, 0), (60, 0)], [0.7, 0.6, 0.5, 0.4, 0.3, 0.2])


def test_greedy_takes_nearest_next() -> None:
    assert plan("greedy", LINE) == {1: [1, 2, 3, 4]}


def test_greedy_follows_the_route_not_the_start() -> None:
    # From (0,0): nearest is id 1 at (5,0); from there id 3 at (5,4) is nearer than id 2 at (-6,0).
    inp = layout([(5, 0), (-6, 0), (5, 4)], [0.5, 0.5, 0.5], capacity=3)
    assert plan("greedy", inp) == {1: [1, 3, 2]}


def test_cautious_takes_lowest_battery_next() -> None:
    assert plan("cautious", LINE) == {1: [6, 5, 4, 3]}


def test_weighted_moves_from_greedy_to_cautious_with_the_energy_scale() -> None:
    assert plan("weighted", LINE, CostWeights(1.0, 0.0)) == plan("greedy", LINE)
    assert plan("weighted", LINE, CostWeights(1e-6, 1.0)) == plan("cautious", LINE)


def test_none_never_collects() -> None:
    assert plan("none", LINE) == {1: []}


def test_capacity_and_ties_are_respected_deterministically() -> None:
    inp = layout([(10, 0), (0, 10), (-10, 0)], [0.5, 0.5, 0.5], capacity=2)
    assert plan("cautious", inp) == {1: [1, 2]}  # equal batteries: lower id first
    few = layout([(10, 0)], [0.5], capacity=4)
    assert plan("greedy", few) == {1: [1]}


def test_several_apads_never_share_an_amussel() -> None:
    inp = PlanInput({1: LINE.apads[1], 2: LINE.apads[1]}, {1: 4, 2: 4}, LINE.mussel_ids,
                    LINE.lat_deg, LINE.lon_deg, LINE.battery_frac)
    result = plan("greedy", inp)
    assert result[1] == [1, 2, 3, 4] and result[2] == [5, 6]


def test_unknown_strategy_names_the_known_ones() -> None:
    with pytest.raises(ValueError, match=r"unknown strategy 'smart'.*cautious"):
        plan("smart", LINE)


def test_a_new_strategy_is_one_registered_function() -> None:
    @strategy("farthest_first")
    def farthest(inp: PlanInput, weights: CostWeights) -> dict[int, list[int]]:
        order = np.argsort(-inp.lon_deg)  # farthest east first
        return {1: [int(inp.mussel_ids[i]) for i in order[:4]]}

    try:
        assert plan("farthest_first", LINE) == {1: [6, 5, 4, 3]}
    finally:
        del STRATEGIES["farthest_first"]


def test_route_length_is_geodesic_metres() -> None:
    stops = [(float(a), float(b)) for a, b in zip(LINE.lat_deg[:3], LINE.lon_deg[:3], strict=True)]
    assert route_length_m(LINE.apads[1], stops) == pytest.approx(30.0, abs=0.01)
    assert route_length_m(LINE.apads[1], []) == 0.0
