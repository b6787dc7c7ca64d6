"""The aMussel table's batch checks: the quick all-valid test never lets a bad row through."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gcs.link.fleet_table import MusselBatch, batch_rejections

GOOD = {"mussel_id": 3, "lat": 439_400_000, "lon": 154_400_000, "depth": 2.5, "battery": 0.5,
        "battery_voltage": 3900, "state": 1, "simulated": 1, "time_us": 10**9}  # fmt: skip
BAD = [("mussel_id", 0), ("lat", 900_000_001), ("lat", -900_000_001), ("lon", 1_800_000_001), ("depth", -0.1),
       ("depth", math.nan), ("depth", math.inf), ("battery", 1.01), ("battery", -0.01), ("battery", math.nan),
       ("state", 6), ("state", -1), ("simulated", 2), ("simulated", -1), ("time_us", 2**63)]  # fmt: skip


@pytest.mark.parametrize(("field", "value"), BAD)
@pytest.mark.parametrize("n", [1, 5, 8, 9, 12, 120])  # row by row up to 8, reductions above
def test_one_bad_row_among_good_ones_is_found(field: str, value: float, n: int) -> None:
    wire = {f: np.full(n, v, np.uint64 if f == "time_us" else (float if isinstance(v, float) else np.int64))
            for f, v in GOOD.items()}
    wire["mussel_id"] = np.arange(1, n + 1)
    assert batch_rejections(MusselBatch.from_wire(wire)) == {}
    wire[field][n // 2] = value
    bad = batch_rejections(MusselBatch.from_wire(wire))
    assert sum(int(mask.sum()) for mask in bad.values()) == 1 and bad  # that row, for one reason
