"""A run's figures per simulated day (result.json's `days`, `gcs.results.days`): a figure and a table.

A simulated day is the aMussels' day, 86,400 s / theta of mission time (theta 30: 48 min), so a
24-h mission is 30 of them and a week 210; every day is shown, whatever the run's length.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from gcs.report.page import table
from gcs.report.run_data import RunData, as_list
from gcs.report.style import apad_colour, figure, grid, palette, save

CAPTION = ("Per simulated day (the aMussels' day: 86,400 s / theta of mission time). Uptime: the fleet's mean "
           "(eq. 3 over the day's steps); alive: not depleted at the day's end (the last day: at the mission's "
           "end); ran flat: first depletions that day; charged: aMussels each aPad docked that day; Wh passed: "
           "energy each aPad passed into them.")


def day_rows(data: RunData) -> list[dict[str, Any]]:
    """result.json's days (the rows of a run that wrote them), [] otherwise."""
    return [d for d in as_list(data.result.get("days")) if isinstance(d, dict) and isinstance(d.get("day"), int)]


def days_png(data: RunData, path: Path) -> Path | None:
    """Top: mean uptime per day (bars) and aMussels alive at its end; below: each aPad's charges and Wh
    passed per day. None for a run of fewer than two days."""
    rows = day_rows(data)
    if len(rows) < 2:
        return None
    fig, (top, bottom) = figure(8.5, 5.6, nrows=2, sharex=True)
    c = palette()
    day = np.array([r["day"] for r in rows])
    top.bar(day, [float(r.get("uptime_pct", 0.0)) for r in rows], color=c[0], width=0.85, label="mean uptime %")
    top.set(ylabel="uptime [%]", ylim=(0, 100), title=f"Per simulated day — {data.title}")
    alive = top.twinx()
    alive.step(day, [int(r.get("alive", 0)) for r in rows], where="mid", color=c[6], lw=1.6,
               label="alive at the day's end")
    alive.set(ylabel="alive aMussels [count]", ylim=(0, data.ids.size + 0.5))
    grid(top)
    handles = top.get_legend_handles_labels()[0] + alive.get_legend_handles_labels()[0]
    top.legend(handles=handles, loc="lower left", fontsize=8)
    apads = sorted({a for r in rows for a in (r.get("charges") or {})}, key=int)
    wh = bottom.twinx()
    for a in apads:
        colour = apad_colour(int(a))
        bottom.step(day, [int((r.get("charges") or {}).get(a, 0)) for r in rows], where="mid", color=colour, lw=1.4,
                    label=f"aPad {a}: aMussels charged")
        passed = [float((r.get("passed_wh") or {}).get(a, np.nan)) for r in rows]
        if np.isfinite(passed).any():
            wh.plot(day, passed, color=colour, ls=":", marker=".", lw=1.0, label=f"aPad {a}: Wh passed")
    bottom.set(xlabel="simulated day", ylabel="aMussels charged [count]")
    wh.set(ylabel="energy passed [Wh]")
    grid(bottom)
    handles = bottom.get_legend_handles_labels()[0] + wh.get_legend_handles_labels()[0]
    if handles:
        bottom.legend(handles=handles, loc="upper right", fontsize=8)
    return save(fig, path)


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
