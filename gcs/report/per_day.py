"""A run's figures per simulated day (result.json's `days`, `gcs.results.days`): a figure and a table.

A simulated day is the aMussels' day, 86,400 s / theta of mission time (theta 30: 48 min), so a
24-h mission is 30 of them and a week 210. The table shows every day, whatever the run's length; the
figure too up to `LONG_DAYS`, beyond which a day's line is too thin to read: then weeks (a band of
the fleet's uptime, heat maps of aPad x week), drawn by `per_week`.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from gcs.report.page import table
from gcs.report.per_week import LONG_DAYS, weeks_figure
from gcs.report.run_data import RunData, as_list
from gcs.report.style import BLACK, apad_colour, figure, grid, legend_above, palette, save

if TYPE_CHECKING:
    from matplotlib.figure import Figure

CAPTION = ("Per simulated day (the aMussels' day: 86,400 s / theta of mission time). Uptime: the fleet's mean "
           "(eq. 3 over the day's steps); alive: not depleted at the day's end (the last day: at the mission's "
           "end); ran flat: first depletions that day; charged: aMussels each aPad docked that day; Wh passed: "
           "energy each aPad passed into them.")


def day_rows(data: RunData) -> list[dict[str, Any]]:
    """result.json's days (the rows of a run that wrote them), [] otherwise."""
    return [d for d in as_list(data.result.get("days")) if isinstance(d, dict) and isinstance(d.get("day"), int)]


def days_png(data: RunData, path: Path) -> Path | None:
    """`days_figure` as a PNG; None for a run of fewer than two days."""
    fig = days_figure(data)
    return None if fig is None else save(fig, path)


def days_figure(data: RunData) -> Figure | None:
    """Each day (`LONG_DAYS` at most; weeks beyond, `per_week.weeks_figure`); None for a run of fewer
    than two days."""
    rows = day_rows(data)
    if len(rows) < 2:
        return None
    return weeks_figure(data, rows) if len(rows) > LONG_DAYS else _days_figure(data, rows)


def _days_figure(data: RunData, rows: list[dict[str, Any]]) -> Figure:
    """Top: mean uptime per day (bars) and aMussels alive at its end; below: each aPad's charges (solid)
    and Wh passed (dotted) per day. The legends sit above their plots, off the data."""
    from matplotlib.lines import Line2D

    fig, (top, bottom) = figure(8.5, 5.6, nrows=2, sharex=True)
    c = palette()
    day = np.array([r["day"] for r in rows])
    top.bar(day, [float(r.get("uptime_pct", 0.0)) for r in rows], color=c[0], width=0.85, label="mean uptime %")
    top.set(ylabel="uptime [%]", ylim=(0, 100))
    fig.suptitle(f"Per simulated day — {data.title}")
    alive = top.twinx()
    alive.step(day, [int(r.get("alive", 0)) for r in rows], where="mid", color=c[6], lw=1.6,
               label="alive at the day's end")
    alive.set(ylabel="alive aMussels [count]", ylim=(0, data.ids.size + 0.5))
    grid(top)
    handles = top.get_legend_handles_labels()[0] + alive.get_legend_handles_labels()[0]
    legend_above(top, handles)
    apads = sorted({a for r in rows for a in (r.get("charges") or {})}, key=int)
    wh = bottom.twinx()
    any_wh = False
    for a in apads:
        colour = apad_colour(int(a))
        bottom.step(day, [int((r.get("charges") or {}).get(a, 0)) for r in rows], where="mid", color=colour, lw=1.4)
        passed = [float((r.get("passed_wh") or {}).get(a, np.nan)) for r in rows]
        if np.isfinite(passed).any():
            any_wh = True
            wh.plot(day, passed, color=colour, ls=":", marker=".", lw=1.0)
    bottom.set(xlabel="simulated day", ylabel="aMussels charged [count]")
    wh.set(ylabel="energy passed [Wh]")
    grid(bottom)
    # One entry per aPad (its colour) and one per quantity (its line): not one per line drawn.
    keys = [Line2D([], [], color=apad_colour(int(a)), lw=2.5, label=f"aPad {a}") for a in apads]
    keys.append(Line2D([], [], color=BLACK, lw=1.4, label="aMussels charged"))
    if any_wh:
        keys.append(Line2D([], [], color=BLACK, ls=":", marker=".", lw=1.0, label="Wh passed"))
    if apads:
        legend_above(bottom, keys)
    return fig


def days_table(data: RunData) -> str:
    """Every day as an HTML table (a paragraph saying why there is none otherwise)."""
    rows = day_rows(data)
    if not rows:
        return "<p>This run wrote no figures per simulated day (runs before they were kept, consoles).</p>"
    apads = sorted({a for r in rows for a in (r.get("charges") or {})}, key=int)
    body = []
    for r in rows:
        charges, passed = r.get("charges") or {}, r.get("passed_wh") or {}
        body.append([r["day"], f"{_h(r.get('from_s', 0.0))}-{_h(r.get('to_s', 0.0))}",
                     f"{float(r.get('uptime_pct', 0.0)):.1f}", r.get("alive", "-"), r.get("depleted", "-"),
                     *(charges.get(a, "-") for a in apads),
                     *(f"{float(passed[a]):.1f}" if a in passed else "-" for a in apads)])
    headers = ("sim. day", "mission time h:mm", "uptime %", "alive", "ran flat",
               *(f"aPad {a} charged" for a in apads), *(f"aPad {a} Wh passed" for a in apads))
    return f'<div class="scroll">{table(headers, body, CAPTION, text_cols=2)}</div>'


def _h(seconds: object) -> str:
    minutes = round(float(seconds) / 60) if isinstance(seconds, int | float) else 0
    return f"{minutes // 60}:{minutes % 60:02d}"
