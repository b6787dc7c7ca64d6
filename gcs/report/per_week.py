"""The per-day figure of a long run (more than `LONG_DAYS` simulated days), by week.

Two hundred days of five aPads' lines are a tangle; what a reader wants from them is the level and
its drift. So, per week of seven simulated days: the fleet's mean uptime as a band (the week's
lowest to highest day) around the week's mean, with the aMussels alive at each day's end; and each
aPad's aMussels charged and Wh passed a day, the week's mean, as heat maps of aPad x week, the
numbers written in the cells while they fit. A mean a day, not the week's sum: the last week may
hold fewer days (its cells are narrower) and reads on the same scale.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from gcs.report.style import SEQUENTIAL_MAP, figure, grid, ink, legend_above, palette

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from gcs.report.run_data import RunData

LONG_DAYS = 30  # more days than this: by week (a day is then under 1/30 of the figure's width)
WEEK_DAYS = 7
WRITTEN_WEEKS = 40  # sums written in the heat maps' cells up to this many weeks (beyond, too narrow to read)


def week_edges(days: NDArray[np.int64]) -> NDArray[np.float64]:
    """The weeks' edges on the simulated-day axis: each week from half a day before its first day to
    half a day after its last (the last week may hold fewer days)."""
    starts = days[::WEEK_DAYS].astype(np.float64) - 0.5
    return np.append(starts, float(days[-1]) + 0.5)


REDUCE: dict[str, Callable[..., Any]] = {"sum": np.nansum, "mean": np.nanmean, "min": np.nanmin, "max": np.nanmax}


def weekly(values: NDArray[np.float64], how: str) -> NDArray[np.float64]:
    """`values` (days along the last axis) per week: their "sum", "mean", "min" or "max" (NaN days
    left out; a week of NaN only is NaN)."""
    out = []
    for k in range(0, values.shape[-1], WEEK_DAYS):
        week = values[..., k:k + WEEK_DAYS]
        seen = np.asarray(np.isfinite(week).any(axis=-1))
        safe = np.where(seen[..., None], week, 0.0)  # a week of NaN only: reduced as zeros, then blanked
        out.append(np.where(seen, REDUCE[how](safe, axis=-1), np.nan))
    return np.stack(out, axis=-1)


def weeks_figure(data: RunData, rows: list[dict[str, Any]]) -> Figure:
    """Top: the fleet's uptime per week (band and mean) and alive at each day's end; below, a heat map
    of aPad x week each for aMussels charged and Wh passed (none if the run recorded no energy)."""
    day = np.array([int(r["day"]) for r in rows], np.int64)
    apads = sorted({a for r in rows for a in (r.get("charges") or {})}, key=int)
    charged = np.array([[float((r.get("charges") or {}).get(a, 0)) for r in rows] for a in apads]).reshape(
        len(apads), day.size)
    passed = np.array([[float((r.get("passed_wh") or {}).get(a, np.nan)) for r in rows] for a in apads]).reshape(
        len(apads), day.size)
    maps = [(charged, "aMussels charged")]
    if np.isfinite(passed).any():
        maps.append((passed, "Wh passed"))
    height = 2.6 + sum(0.6 + 0.28 * len(apads) for _ in maps)
    fig, axes = figure(9.0, height, nrows=1 + len(maps), sharex=True,
                       height_ratios=[2.6] + [0.6 + 0.28 * len(apads)] * len(maps))
    edges = week_edges(day)
    _uptime_band(axes[0], data, rows, day, edges)
    for ax, (values, what) in zip(axes[1:], maps, strict=True):
        _heat_map(fig, ax, weekly(values, "mean"), edges, apads, what)
    axes[-1].set_xlabel(f"simulated day (cells: weeks of {WEEK_DAYS} days)")
    fig.suptitle(f"Per simulated week, {day.size} days — {data.title}")
    return fig


def _uptime_band(ax: Axes, data: RunData, rows: list[dict[str, Any]], day: NDArray[np.int64],
                 edges: NDArray[np.float64]) -> None:
    c = palette()
    uptime = np.array([float(r.get("uptime_pct", np.nan)) for r in rows])
    lo, hi, mean = (weekly(uptime, how) for how in ("min", "max", "mean"))
    ax.stairs(hi, edges, baseline=lo, fill=True, color=c[0], alpha=0.3, lw=0, label="uptime: the week's days")
    ax.stairs(mean, edges, color=c[0], lw=1.8, label="uptime: the week's mean")
    ax.set(ylabel="fleet uptime [%]", ylim=(0, 100))
    grid(ax)
    alive = ax.twinx()
    alive.step(day, [int(r.get("alive", 0)) for r in rows], where="mid", color=c[6], lw=1.4,
               label="aMussels alive at the day's end")
    alive.set(ylabel="alive aMussels [count]", ylim=(0, data.ids.size + 0.5))
    legend_above(ax, ax.get_legend_handles_labels()[0] + alive.get_legend_handles_labels()[0])


def _heat_map(fig: Figure, ax: Axes, means: NDArray[np.float64], edges: NDArray[np.float64], apads: list[str],
              what: str) -> None:
    """aPad x week, cividis (dark few, yellow many); blank where nothing was recorded."""
    import matplotlib

    y = np.arange(len(apads) + 1) - 0.5
    finite = means[np.isfinite(means)]
    top = float(finite.max()) if finite.size and finite.max() > 0 else 1.0
    mesh = ax.pcolormesh(edges, y, np.ma.masked_invalid(means), cmap=SEQUENTIAL_MAP, vmin=0.0, vmax=top,
                         edgecolors="white", linewidth=0.5)
    ax.set_yticks(range(len(apads)), [f"aPad {a}" for a in apads])
    ax.set_ylim(len(apads) - 0.5, -0.5)  # aPad 1 on top, as in the tables
    fig.colorbar(mesh, ax=ax, label=f"{what} a day", pad=0.01, aspect=10)
    weeks = means.shape[1]
    if weeks <= WRITTEN_WEEKS:  # the numbers, so nothing rests on colour alone
        cmap = matplotlib.colormaps[SEQUENTIAL_MAP]
        centres = (edges[:-1] + edges[1:]) / 2
        wide = np.diff(edges) >= WEEK_DAYS / 2  # a last week of a few days is too narrow for a number
        fmt = "{:.0f}" if top >= 20 else "{:.1f}"
        for i in range(means.shape[0]):
            for k in range(weeks):
                if wide[k] and np.isfinite(means[i, k]):
                    ax.text(centres[k], i, fmt.format(means[i, k]), ha="center", va="center",
                            fontsize=8 if weeks <= 15 else 6, color=ink(cmap(means[i, k] / top)[:3]))
    ax.set_title(f"{what} a day, each aPad's mean over each week", fontsize=9, loc="left")
