"""Every plan passes `check_plan` before the loop acts on it (issue 22): what a strategy from outside
may get wrong, each refused in one line; and every shipped strategy's plans pass it."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gcs.strategies import COLLECT, PlanInput, StrategyError, check_plan, plan

INP = PlanInput(apads={1: (43.94, 15.44), 2: (43.9401, 15.4401)}, capacity={1: 2, 2: 1},
                mussel_ids=np.array([3, 5, 8], np.int64), lat_deg=np.array([43.94, 43.9402, 43.9403]),
                lon_deg=np.array([15.4402, 15.4403, 15.4404]), battery_frac=np.array([0.5, 0.7, 0.2]))


@pytest.mark.parametrize("made, words", [
    ([3], "returned list, not a dict"),
    ({7: [3]}, "planned for aPad 7, which is not planning now"),
    ({1: (3, 5)}, "route is not a list of aMussel ids"),
    ({1: [True]}, "route is not a list of aMussel ids"),
    ({1: [4]}, "planned aMussel 4, which is not a candidate"),
    ({1: [3, 3]}, "planned aMussel 3 twice"),
    ({1: [3], 2: [3]}, "planned aMussel 3 twice"),
    ({1: [3, 5, 8]}, "planned 3 aMussels for aPad 1's 2 free slots"),
])
def test_a_plan_the_loop_cannot_act_on_is_one_line_saying_why(made: object, words: str) -> None:
    with pytest.raises(StrategyError) as caught:
        check_plan("mine", made, INP)
    assert words in str(caught.value) and "\n" not in str(caught.value)


def test_numpy_ids_are_taken_as_ints() -> None:
    checked = check_plan("mine", {1: [np.int64(8), np.int32(3)], 2: []}, INP)
    assert checked == {1: [8, 3], 2: []} and all(type(m) is int for m in checked[1])


@settings(max_examples=60, deadline=None)
@given(n=st.integers(0, 9), free=st.integers(0, 4), seed=st.integers(0, 2**16))
def test_every_shipped_strategy_plans_what_the_loop_can_act_on(n: int, free: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    inp = PlanInput(apads={1: (43.94, 15.44)}, capacity={1: free}, mussel_ids=rng.permutation(50)[:n] + 1,
                    lat_deg=43.94 + rng.uniform(0, 3e-4, n), lon_deg=15.44 + rng.uniform(0, 3e-4, n),
                    battery_frac=rng.uniform(0.0, 0.8, n))
    for name in COLLECT:
        made = plan(name, inp)  # check_plan inside: a bad plan raises
        assert len(made.get(1, [])) <= free
