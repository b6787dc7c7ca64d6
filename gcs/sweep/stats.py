"""Figures across a sweep's runs: means with 95 % intervals, and which configurations are on the
Pareto front (no other has at least as much uptime, average and minimum, for no more travel)."""

from __future__ import annotations

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from scipy import stats

CONFIDENCE = 0.95
# The figures compared: (column, what is better). Uptime up, movement cost down.
OBJECTIVES = (("uptime.avg", 1.0), ("uptime.min", 1.0), ("cost_m", -1.0))
FIGURES = ("uptime.avg", "uptime.min", "uptime.max", "cost_m", "active_avg")


def mean_ci(values: ArrayLike) -> tuple[float, float]:
    """(mean, half-width of its 95 % interval, Student's t); the half-width is NaN below two values."""
    x = np.asarray(values, np.float64)
    x = x[np.isfinite(x)]
    if x.size == 0:
        return float("nan"), float("nan")
    if x.size < 2:
        return float(x.mean()), float("nan")
    half = stats.t.ppf(0.5 + CONFIDENCE / 2, x.size - 1) * x.std(ddof=1) / np.sqrt(x.size)
    return float(x.mean()), float(half)


def pareto_front(scores: NDArray[np.float64]) -> NDArray[np.bool_]:
    """(n, k) scores, higher better in every column -> (n,) True where no other row dominates
    (at least as good in every column and better in one)."""
    s = np.asarray(scores, np.float64)
    at_least = (s[:, None, :] >= s[None, :, :]).all(axis=2)  # [i, j]: i at least as good as j everywhere
    better = (s[:, None, :] > s[None, :, :]).any(axis=2)
    dominated = (at_least & better).any(axis=0)
    return np.asarray(~dominated)


def summary(rows: pd.DataFrame, by: list[str]) -> pd.DataFrame:
    """One row per group: n, and mean and 95 % half-width of each figure; `front` per scenario."""
    out = []
    for keys, group in rows.groupby(by, sort=False, dropna=False):
        entry = dict(zip(by, keys if isinstance(keys, tuple) else (keys,), strict=True)) | {"n": len(group)}
        for figure in FIGURES:
            if figure in group:
                entry[f"{figure}.mean"], entry[f"{figure}.ci95"] = mean_ci(group[figure])
        out.append(entry)
    table = pd.DataFrame(out)
    table["front"] = False
    for _, idx in table.groupby("scenario", sort=False).groups.items():
        scores = np.column_stack([sign * table.loc[idx, f"{col}.mean"].to_numpy(np.float64)
                                  for col, sign in OBJECTIVES])
        table.loc[idx, "front"] = pareto_front(scores)
    return table
