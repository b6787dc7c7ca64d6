"""A spec's `{min = A, max = B}` range of a field, read once for `[sample]`, `[sensitivity]` and `vil tune`'s
`[search]` (each says in its own words what it refuses)."""

from __future__ import annotations

import math
from typing import Any


def is_range(value: Any) -> bool:
    return isinstance(value, dict) and set(value) == {"min", "max"}


def numeric_bounds(value: Any) -> tuple[float, float, bool] | None:
    """A range of finite numbers as (A, B, whether both are integers); None if `value` is not one (A > B is
    the caller's to refuse or allow)."""
    if not is_range(value):
        return None
    lo, hi = value["min"], value["max"]
    if not all(isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in (lo, hi)):
        return None
    return float(lo), float(hi), isinstance(lo, int) and isinstance(hi, int)
