"""`mussel_sim.memo.LastMade`: the answer for the last objects, made again only for other objects."""

from __future__ import annotations

import numpy as np

from mussel_sim.memo import LastMade


def test_made_once_for_the_same_objects_and_again_for_others_even_if_equal() -> None:
    made: list[tuple[int, ...]] = []

    def count(*arrays: np.ndarray) -> int:
        made.append(tuple(id(a) for a in arrays))
        return int(sum(a.sum() for a in arrays))

    memo = LastMade(count)
    a, b = np.array([1, 2]), np.array([3])
    assert memo(a, b) == 6 and memo(a, b) == 6 and len(made) == 1
    assert memo(a.copy(), b) == 6 and len(made) == 2  # equal, but another object: made again
    assert memo(a) == 3 and len(made) == 3  # fewer keys: another question
