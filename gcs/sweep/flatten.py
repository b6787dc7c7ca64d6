"""A run's result.json as one flat row of columns, whatever fields it has.

Nested dicts become dotted columns (`uptime.avg`, `messages.gcs_sent`). A list of records (one
per aMussel, one per aPad) is summarised: `mussels.n`, and per numeric field its mean, min and
max over the list (`mussels.uptime_pct.min`, `mussels.state_s.floating.max`); a list inside a
record counts its items (`mussels.dockings`: how many per aMussel, then summarised); None is no
value (`first_depleted_s` of an aMussel that never depleted: `mussels.first_depleted_s.min` is
the run's first depletion, empty if none did); a short word field counts each word
(`whereabouts.where=seabed`). A list of numbers gets n, mean, min, max. Identifiers (`id`,
`sysid`, `*_id`) are not figures and are left out. New fields of result.json become columns with
no change here.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable
from typing import Any

Row = dict[str, Any]  # column -> number, string, bool or None
WORD = re.compile(r"^[a-z][a-z0-9_]{0,31}$")  # a state or a place, not a sentence
SUMMARIES = ("mean", "min", "max")


def flatten(result: dict[str, Any], prefix: str = "") -> Row:
    row: Row = {}
    for key, value in result.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            row |= flatten(value, f"{name}.")
        elif isinstance(value, list):
            row |= _summarise_list(name, value)
        else:
            row[name] = value
    return row


def _is_id(key: str) -> bool:
    last = key.rsplit(".", 1)[-1]
    return last in ("id", "sysid") or last.endswith("_id")


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _summarise_list(name: str, items: list[Any]) -> Row:
    row: Row = {f"{name}.n": len(items)}
    if items and all(isinstance(v, dict) for v in items):
        records = [_record_leaves(v) for v in items]
        keys = list(dict.fromkeys(k for r in records for k in r))  # first-seen order: stable columns
        for key in keys:
            if _is_id(key):
                continue
            values: list[Any] = [r.get(key) for r in records]
            numbers = [v for v in values if _is_number(v)]
            if numbers or all(v is None for v in values):  # None: not yet (e.g. never depleted); columns kept
                row |= _stats(f"{name}.{key}", numbers)
            else:
                for word in sorted({v for v in values if isinstance(v, str) and WORD.match(v)}):
                    row[f"{name}.{key}={word}"] = sum(v == word for v in values)
    elif items and all(_is_number(v) for v in items) and not _is_id(name):
        row |= _stats(name, items)
    return row


def _record_leaves(record: dict[str, Any]) -> dict[str, Any]:
    """One record's fields, nested dicts dotted and lists replaced by their length."""
    out: dict[str, Any] = {}
    for key, value in record.items():
        if isinstance(value, dict):
            out |= {f"{key}.{k}": v for k, v in _record_leaves(value).items()}
        elif isinstance(value, list):
            out[key] = len(value)
        else:
            out[key] = value
    return out


def _stats(name: str, numbers: Iterable[float]) -> Row:
    values = [float(v) for v in numbers if math.isfinite(float(v))]
    if not values:
        return {f"{name}.{s}": None for s in SUMMARIES}
    return {f"{name}.mean": round(math.fsum(values) / len(values), 6), f"{name}.min": min(values),
            f"{name}.max": max(values)}
