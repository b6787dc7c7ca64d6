"""The aPad's table of aMussel fixes: validated once, stored as received, converted to metres lazily."""

from __future__ import annotations

from collections import Counter
from typing import Any

import numpy as np
import pytest

from apad_sitl.docking import MusselFixTable
from mussel_sim.geo import LocalFrame
from mussel_sim.vocabulary import MusselState

HOME = (43.94, 15.44)
FLOATING, DOCKED = int(MusselState.FLOATING), int(MusselState.DOCKED)


class CountingFrame(LocalFrame):
    """A LocalFrame that counts its conversions to local metres."""

    def __init__(self) -> None:
        super().__init__(*HOME)
        self.to_local_calls = 0

    def to_local(self, lat_deg: Any, lon_deg: Any) -> Any:
        self.to_local_calls += 1
        return super().to_local(lat_deg, lon_deg)


def e7(x_m: float, y_m: float) -> tuple[int, int]:
    lat, lon = LocalFrame(*HOME).to_geodetic(x_m, y_m)
    return round(float(lat) * 1e7), round(float(lon) * 1e7)


def arrays(rows: list[tuple[int, int, int, int]], dtype: Any = np.int64) -> tuple[np.ndarray, ...]:
    return tuple(np.array(col, dtype=dtype) for col in zip(*rows, strict=True))


def test_update_converts_to_metres_only_when_asked_and_once_per_new_fix() -> None:
    frame = CountingFrame()
    table = MusselFixTable(frame)
    for _ in range(3):
        assert table.update(24, *e7(3.0, 4.0), FLOATING)
    assert frame.to_local_calls == 0 and len(table) == 1 and list(table) == [24]
    fix = table[24]
    assert (fix.x_m, fix.y_m, fix.docked) == (pytest.approx(3.0, abs=0.01), pytest.approx(4.0, abs=0.01), False)
    assert table[24] is fix and frame.to_local_calls == 1
    table.update(24, *e7(3.0, 4.0), FLOATING)  # the same fix again: the cache stands
    assert table[24] is fix
    table.update(24, *e7(3.0, 4.0), DOCKED)
    assert table[24].docked and frame.to_local_calls == 2
    assert table.get(99) is None


@pytest.mark.parametrize(("row", "field"), [
    ((0, 0, 0, FLOATING), "mussel_id"),
    ((-5, 0, 0, FLOATING), "mussel_id"),
    ((65536, 0, 0, FLOATING), "mussel_id"),
    ((7, 900_000_001, 0, FLOATING), "lat"),
    ((7, -(2**31), 0, FLOATING), "lat"),
    ((7, 0, 1_800_000_001, FLOATING), "lon"),
    ((7, 0, -1_800_000_001, FLOATING), "lon"),
    ((7, 0, 0, 6), "state"),
    ((7, 0, 0, -1), "state"),
    ((0, 2**31 - 1, 2**31 - 1, 99), "mussel_id"),  # counted once, by its first bad field
])
def test_a_bad_status_is_dropped_and_counted_by_its_first_bad_field(row: tuple[int, int, int, int], field: str) -> None:
    dropped: Counter[str] = Counter()
    one = MusselFixTable(LocalFrame(*HOME), dropped)
    assert not one.update(*row)
    assert len(one) == 0 and dropped == Counter({f"invalid:AMUSSEL_STATUS:{field}": 1})
    batch = MusselFixTable(LocalFrame(*HOME), dropped)
    assert batch.update_many(*arrays([row])) == 0
    assert len(batch) == 0 and dropped == Counter({f"invalid:AMUSSEL_STATUS:{field}": 2})


def test_update_many_takes_the_good_rows_in_order_and_counts_the_rest() -> None:
    dropped: Counter[str] = Counter()
    frame = CountingFrame()
    table = MusselFixTable(frame, dropped)
    rows = [
        (3, *e7(1.0, 0.0), FLOATING),
        (0, *e7(1.0, 0.0), FLOATING),  # no id
        (5, *e7(0.0, 2.0), DOCKED),
        (3, *e7(5.0, 0.0), FLOATING),  # a later fix of 3 wins
        (6, 2**31 - 1, 0, FLOATING),  # no latitude
        (8, *e7(0.0, 0.0), 200),  # no state
        (6, *e7(0.0, 0.0), 200),
    ]
    assert table.update_many(*arrays(rows, np.int32)) == 3
    assert dropped == Counter({"invalid:AMUSSEL_STATUS:mussel_id": 1, "invalid:AMUSSEL_STATUS:lat": 1,
                               "invalid:AMUSSEL_STATUS:state": 2})
    assert list(table) == [3, 5] and frame.to_local_calls == 0
    assert table[3].x_m == pytest.approx(5.0, abs=0.01) and table[5].docked


def test_update_many_and_update_agree() -> None:
    rng = np.random.default_rng(7)
    n = 500
    ids = rng.integers(-2, 40, n)
    lat = rng.integers(-950_000_000, 950_000_000, n)
    lon = rng.integers(-1_900_000_000, 1_900_000_000, n)
    state = rng.integers(-1, 8, n)
    d1: Counter[str] = Counter()
    d2: Counter[str] = Counter()
    one, batch = MusselFixTable(LocalFrame(*HOME), d1), MusselFixTable(LocalFrame(*HOME), d2)
    taken = sum(one.update(*(int(c[i]) for c in (ids, lat, lon, state))) for i in range(n))
    assert batch.update_many(ids, lat, lon, state) == taken > 0
    assert d1 == d2 and sum(d1.values()) == n - taken
    assert list(one) == list(batch)
    assert [one[i] for i in one] == [batch[i] for i in batch]


@pytest.mark.parametrize("columns", [
    (np.array([1, 2]), np.array([0, 0]), np.array([0, 0]), np.array([2])),  # lengths differ
    (np.array([[1]]), np.array([[0]]), np.array([[0]]), np.array([[2]])),  # not (n,)
    (np.array([1.0]), np.array([0]), np.array([0]), np.array([2])),  # float ids
    (np.array([1]), np.array([np.nan]), np.array([0]), np.array([2])),
])
def test_update_many_refuses_columns_that_are_not_integer_arrays_of_one_shape(columns: tuple[np.ndarray, ...]) -> None:
    table = MusselFixTable(LocalFrame(*HOME))
    with pytest.raises(ValueError, match=r"integer arrays of one shape \(n,\)"):
        table.update_many(*columns)
    assert len(table) == 0


def test_update_many_of_nothing_is_nothing() -> None:
    table = MusselFixTable(LocalFrame(*HOME))
    empty = np.array([], dtype=np.int64)
    assert table.update_many(empty, empty, empty, empty) == 0 and not table.dropped
