"""A sweep spec's `[sensitivity]` table: which scenario fields vary, within which bounds, sampled how.

    [sensitivity]
    method = "sobol"          # Saltelli's sample, Sobol indices (SALib); or "morris": elementary effects
    n = 256                   # base samples: sobol runs n(2D+2) points for D fields (n(D+2) without
                              # second order), morris n(D+1) (n trajectories)
    seed = 1                  # the sample's seed: the same spec samples the same points
    second_order = true       # sobol: the pairs' indices too (and the n(2D+2) points they need)
    levels = 4                # morris: the grid levels of each field
    outputs = ["uptime_min", "alive_at_end", "apad_wh_per_day"]   # what the analysis explains (`OUTPUTS`)
    mission.pool_threshold = {min = 0.6, max = 0.9}
    apad.slots = {min = 2, max = 4}                                # integers if both bounds are

The sample is SALib's (the field's library for it, not a hand-rolled one): each point is a mission per seed
of `[sweep] seeds`, run as any grid's cells are (Dask, resumable, Parquet), and the analysis
(`gcs.sweep.sensitivity`) takes the mean over the seeds at each point. A field with integer bounds is rounded
to the nearest integer at each point (drawn over [min - 0.5, max + 0.5], so every value is as likely): the
indices then say what its rounded values explain (Morris's effects are divided by the unrounded step).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

import numpy as np
from numpy.typing import NDArray

from gcs.sweep.bounds import is_range, numeric_bounds
from gcs.sweep.outputs import DEFAULT_OUTPUTS, OUTPUTS

MAX_BASE = 65_536
MAX_LEVELS = 64


class Method(StrEnum):
    SOBOL = "sobol"
    MORRIS = "morris"


@dataclass(frozen=True)
class Design:
    """The sensitivity study of a spec: its method, its fields' bounds, its sample's size and seed."""

    method: Method
    names: tuple[str, ...]  # scenario fields as TABLE.FIELD, in the spec's order
    bounds: tuple[tuple[float, float], ...]
    integer: tuple[bool, ...]  # rounded to integers (both bounds integers)
    n: int
    seed: int
    second_order: bool = True
    levels: int = 4
    outputs: tuple[str, ...] = DEFAULT_OUTPUTS

    def problem(self) -> dict[str, Any]:
        """SALib's problem definition. An integer field is drawn over [min - 0.5, max + 0.5] and rounded, so each
        of its values is as likely as the next (its ends too)."""
        bounds = [[lo - 0.5, hi + 0.5] if whole else [lo, hi] for (lo, hi), whole in zip(self.bounds, self.integer,
                                                                                           strict=True)]
        return {"num_vars": len(self.names), "names": list(self.names), "bounds": bounds}

    def sample(self) -> NDArray[np.float64]:
        """The points as SALib draws them `(points, D)` (before rounding)."""
        if self.method is Method.SOBOL:
            from SALib.sample import sobol

            return np.asarray(sobol.sample(self.problem(), self.n, calc_second_order=self.second_order,
                                           seed=self.seed), np.float64)
        from SALib.sample import morris

        return np.asarray(morris.sample(self.problem(), self.n, num_levels=self.levels, seed=self.seed), np.float64)

    def points(self) -> list[dict[str, Any]]:
        """One dict of field values per point, in the sample's order (the analysis needs it)."""
        out = []
        for row in self.sample():
            out.append({name: int(np.clip(np.rint(v), lo, hi)) if whole else float(f"{v:.9g}")
                        for name, v, whole, (lo, hi) in zip(self.names, row, self.integer, self.bounds, strict=True)})
        return out

    def size(self) -> int:
        d = len(self.names)
        if self.method is Method.MORRIS:
            return self.n * (d + 1)
        return self.n * (2 * d + 2 if self.second_order else d + 2)

    def to_json(self) -> dict[str, Any]:
        return {"method": str(self.method), "names": list(self.names), "bounds": [list(b) for b in self.bounds],
                "integer": list(self.integer), "n": self.n, "seed": self.seed, "second_order": self.second_order,
                "levels": self.levels, "outputs": list(self.outputs)}

    @staticmethod
    def from_json(data: dict[str, Any]) -> Design:
        bounds = tuple((float(a), float(b)) for a, b in data["bounds"])
        return Design(Method(data["method"]), tuple(data["names"]), bounds,
                      tuple(bool(i) for i in data["integer"]), int(data["n"]), int(data["seed"]),
                      bool(data["second_order"]), int(data["levels"]), tuple(data["outputs"]))


def parse(table: dict[str, Any], fields_of: Callable[[dict[str, Any], str], dict[str, Any]],
          fail: Callable[[str], Exception]) -> Design:
    """The `[sensitivity]` table (its fields dotted by `fields_of`, as [set]'s are); `fail` makes the one-line
    error naming the entry."""
    table = dict(table)
    try:
        method = Method(table.pop("method", "sobol"))
    except ValueError:
        raise fail(f"sensitivity.method: expected one of {', '.join(m.value for m in Method)}") from None
    n = _integer(table.pop("n", None), "n", 1, MAX_BASE, fail)
    seed = _integer(table.pop("seed", 0), "seed", 0, 2**32 - 1, fail)
    second_order = table.pop("second_order", True)
    if not isinstance(second_order, bool):
        raise fail(f"sensitivity.second_order: expected true or false, got {second_order!r}")
    levels = _integer(table.pop("levels", 4), "levels", 2, MAX_LEVELS, fail)
    if method is Method.MORRIS and levels % 2:
        raise fail(f"sensitivity.levels: Morris needs an even number of levels, got {levels}")
    outputs = table.pop("outputs", list(DEFAULT_OUTPUTS))
    if not isinstance(outputs, list) or not outputs or not all(isinstance(o, str) for o in outputs):
        raise fail(f"sensitivity.outputs: expected a list of output names, got {outputs!r}")
    unknown = [o for o in outputs if o not in OUTPUTS]
    if unknown:
        raise fail(f"sensitivity.outputs: {unknown[0]!r} is not an output (known: {', '.join(OUTPUTS)})")
    if method is Method.SOBOL and n & (n - 1):
        raise fail(f"sensitivity.n: Sobol's sequence needs a power of 2 (e.g. 256), got {n}")
    fields = fields_of(table, "sensitivity")
    if len(fields) < 2:
        raise fail("sensitivity: at least two fields to vary, each as TABLE.FIELD = {min = A, max = B}")
    bounds, integer = [], []
    for key, value in fields.items():
        if not is_range(value):
            raise fail(f"sensitivity.{key}: expected {{min = A, max = B}}, got {value!r}")
        found = numeric_bounds(value)
        if found is None or not found[0] < found[1]:
            raise fail(f"sensitivity.{key}: expected {{min = A, max = B}} with numbers A < B, got {value!r}")
        bounds.append(found[:2])
        integer.append(found[2])
    return Design(method, tuple(fields), tuple(bounds), tuple(integer), n, seed, second_order, levels, tuple(outputs))


def _integer(value: Any, key: str, lo: int, hi: int, fail: Callable[[str], Exception]) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        raise fail(f"sensitivity.{key}: expected an integer in [{lo}, {hi}], got {value!r}")
    return value
