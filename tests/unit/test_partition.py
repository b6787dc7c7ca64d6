"""The fleet split among aPads: every aMussel exactly once, no aPad over its capacity, clusters kept together."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gcs.swarm.partition import partition


def _blobs(rng: np.random.Generator, centres: list[tuple[float, float]], per: int, spread: float) -> np.ndarray:
    return np.vstack([rng.normal(c, spread, size=(per, 2)) for c in centres])


def test_well_separated_groups_go_whole_to_the_apad_nearest_them() -> None:
    rng = np.random.default_rng(3)
    groups = [(0.0, 0.0), (500.0, 0.0), (0.0, 500.0)]
    xy = _blobs(rng, groups, 10, 20.0)
    ids = np.arange(101, 131)
    apads = {7: (480.0, 20.0), 3: (10.0, -30.0), 5: (-20.0, 520.0)}  # each near one group, ids out of order
    p = partition(ids, xy, apads, seed=1)
    assert p.shares == {3: list(range(101, 111)), 7: list(range(111, 121)), 5: list(range(121, 131))}
    assert np.hypot(*np.subtract(p.centres[7], groups[1])) < 20.0
    assert p.owner()[115] == 7


def test_no_apad_gets_more_than_its_capacity_even_when_the_fleet_is_lopsided() -> None:
    rng = np.random.default_rng(5)
    xy = np.vstack([rng.normal((0, 0), 5.0, size=(20, 2)), rng.normal((300, 0), 5.0, size=(4, 2))])
    ids = np.arange(1, 25)
    p = partition(ids, xy, {1: (0.0, 0.0), 2: (300.0, 0.0)}, capacity=14)
    assert sorted(len(s) for s in p.shares.values()) == [10, 14]
    assert set(range(21, 25)) <= set(p.shares[2])  # the far group stays with its aPad
    p_even = partition(ids, xy, {1: (0.0, 0.0), 2: (300.0, 0.0)})  # default: the even share
    assert [len(p_even.shares[a]) for a in (1, 2)] == [12, 12]


def test_impossible_or_empty_requests() -> None:
    ids = np.arange(1, 6)
    xy = np.zeros((5, 2))
    with pytest.raises(ValueError, match="cannot serve"):
        partition(ids, xy, {1: (0.0, 0.0), 2: (1.0, 0.0)}, capacity=2)
    with pytest.raises(ValueError, match="no aPad"):
        partition(ids, xy, {})
    assert partition(ids[:0], xy[:0], {1: (0.0, 0.0), 2: (5.0, 5.0)}).shares == {1: [], 2: []}
    one = partition(ids, xy, {4: (0.0, 0.0)})
    assert one.shares == {4: [1, 2, 3, 4, 5]}
    # Fewer aMussels than aPads: each goes to the nearest aPad, one each.
    apads = {1: (99.0, 0.0), 2: (1.0, 0.0), 3: (50.0, 50.0)}
    few = partition(np.array([8, 9]), np.array([[0.0, 0.0], [100.0, 0.0]]), apads)
    assert few.shares == {1: [9], 2: [8], 3: []}


@settings(max_examples=60, deadline=None)
@given(n=st.integers(0, 60), k=st.integers(1, 6), seed=st.integers(0, 2**16), slack=st.integers(0, 3))
def test_every_amussel_is_served_exactly_once_within_capacity(n: int, k: int, seed: int, slack: int) -> None:
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-200, 200, size=(n, 2))
    ids = rng.permutation(1000)[:n] + 1
    apads = {10 + a: (float(rng.uniform(-200, 200)), float(rng.uniform(-200, 200))) for a in range(k)}
    cap = -(-n // k) + slack
    p = partition(ids, xy, apads, capacity=cap, seed=seed)
    served = [m for share in p.shares.values() for m in share]
    assert sorted(served) == sorted(ids.tolist())
    assert all(len(s) <= cap for s in p.shares.values())
    assert set(p.shares) == set(apads)
    assert p == partition(ids, xy, apads, capacity=cap, seed=seed)  # the same inputs, the same split
