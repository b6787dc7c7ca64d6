"""One run's figures over mission time and per aMussel: battery, states, active count, uptime,
and where each aPad's time went. Each function draws one PNG and returns its path."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gcs.report.run_data import APAD_SHARES, UNHEARD, RunData, as_list
from gcs.report.style import (
    BLACK,
    GREY,
    MAX_DISTINCT,
    SEQUENTIAL_MAP,
    STATE_ORDER,
    apad_colour,
    figure,
    grid,
    ink,
    palette,
    save,
    series_style,
    state_colours,
)

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes


LONG_S = 6 * 3600.0  # a run longer than this is drawn in hours, not minutes (a week is 10,080 min)


def time_unit(data: RunData) -> tuple[float, str]:
    """(seconds per unit, its name) of the mission-time axes: minutes, or hours for a long run."""
    return (3600.0, "h") if data.end_s > LONG_S else (60.0, "min")


def minutes(data: RunData) -> np.ndarray:
    """The history's times in the axes' unit (`time_unit`: minutes, or hours for a long run)."""
    return data.t_s / time_unit(data)[0]


def time_label(data: RunData, what: str = "mission time") -> str:
    return f"{what} [{time_unit(data)[1]}]"


def battery_png(data: RunData, path: Path) -> Path:
    """Every aMussel's battery, a (colour, line style, marker) each; past MAX_DISTINCT the spread."""
    fig, ax = figure(8.5, 4.2)
    grid(ax)
    t = minutes(data)
    pct = 100.0 * data.battery.astype(np.float64)
    n = data.ids.size
    ax.axhline(100 * data.pool_threshold, color=GREY, ls="--", lw=1,
               label=f"pool threshold {100 * data.pool_threshold:.0f} %")
    if n <= MAX_DISTINCT:
        every = max(t.size // 6, 1)
        for c, mussel in enumerate(data.ids):
            s = series_style(c)
            ax.plot(t, pct[:, c], color=s.colour, ls=s.line, marker=s.marker, ms=4, lw=1.3,
                    markevery=(c * every // max(n, 1), every), label=str(mussel))
        ax.legend(title="aMussel", ncols=2, fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.5))
        # (the threshold line is the legend's first entry)
    elif pct.size:
        heard = np.asarray(np.isfinite(pct).any(axis=1))
        lo, mid, hi = (np.full(t.size, np.nan) for _ in range(3))
        lo[heard], mid[heard], hi[heard] = np.nanpercentile(pct[heard], [10, 50, 90], axis=1)
        ax.fill_between(t, lo, hi, color=palette()[0], alpha=0.3, lw=0, label="10th-90th percentile")
        ax.plot(t, mid, color=palette()[0], lw=1.5, label="median")
        ax.plot(t, np.nanmin(np.where(heard[:, None], pct, 100.0), axis=1), color=palette()[2], lw=1, ls=":",
                label="lowest")
        ax.legend(fontsize=8, loc="lower left")
    ax.set(xlabel=time_label(data), ylabel="battery [% of the 3.6-4.2 V range]", ylim=(0, 102),
           title=f"aMussel battery levels — {data.title}")
    return save(fig, path)


def battery_map_png(data: RunData, path: Path) -> Path:
    """Battery as a colour map, a row per aMussel: readable for any fleet size."""
    fig, ax = figure(8.5, max(2.5, min(0.22 * data.ids.size + 1.2, 9.0)))
    t_end = float(minutes(data)[-1]) if data.t_s.size else 0.0
    image = ax.imshow(100.0 * data.battery.T.astype(np.float64), aspect="auto", interpolation="nearest",
                      cmap=SEQUENTIAL_MAP, vmin=0, vmax=100, extent=(0, max(t_end, 1 / 60), data.ids.size - 0.5, -0.5))
    _mussel_ticks(ax, data)
    ax.set(xlabel=time_label(data), ylabel="aMussel id", title=f"Battery per aMussel over time — {data.title}")
    fig.colorbar(image, ax=ax, label="battery [%]", pad=0.01)
    return save(fig, path)


def states_png(data: RunData, path: Path) -> Path:
    """Left: each aMussel's state over time; right: its mission time per state, stacked."""
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    colours = state_colours()
    n = data.ids.size
    fig, (line, bars) = figure(10.0, max(3.0, min(0.25 * n + 1.6, 10.0)), ncols=2, sharey=True,
                               gridspec_kw={"width_ratios": (3, 1)})
    lut = [(1.0, 1.0, 1.0)] * 256  # unheard: white
    for state, colour in colours.items():
        lut[int(state)] = colour
    t_end = float(minutes(data)[-1]) if data.t_s.size else 0.0
    line.imshow(data.state.T, aspect="auto", interpolation="nearest", cmap=ListedColormap(lut), vmin=0,
                vmax=UNHEARD, extent=(0, max(t_end, 1 / 60), n - 0.5, -0.5))
    line.set(xlabel=time_label(data), ylabel="aMussel id", title="State over time")
    _mussel_ticks(line, data)
    left = np.zeros(n)
    rows = np.arange(n)
    for state in STATE_ORDER:
        width = np.array([m.state_s.get(state.name.lower(), 0.0) for m in data.mussels]) / time_unit(data)[0]
        bars.barh(rows, width, left=left, color=colours[state], height=0.8)
        left += width
    bars.set(xlabel=time_label(data, "time in state"), title="Time per state")
    grid(bars)
    handles = [Patch(color=colours[s], label=s.name.lower()) for s in STATE_ORDER]
    fig.legend(handles=handles, loc="outside lower center", ncols=len(handles), fontsize=8)
    fig.suptitle(f"aMussel states — {data.title}")
    return save(fig, path)


def active_png(data: RunData, path: Path) -> Path:
    fig, ax = figure()
    grid(ax)
    c = palette()
    ax.step(minutes(data), data.active, where="post", color=c[0], lw=1.5, label="active aMussels")
    if data.active.size:  # the index (result.json's where the run wrote one): the number the tables show
        mean = data.indices.active_avg
        ax.axhline(mean, color=c[6], ls="--", lw=1.2, label=f"mean {mean:.2f}")
    ax.set(xlabel=time_label(data), ylabel="active aMussels [count]", ylim=(0, data.ids.size + 0.5),
           title=f"Active aMussels over time — {data.title}")
    ax.yaxis.get_major_locator().set_params(integer=True)
    ax.legend(loc="lower left")
    return save(fig, path)


def uptime_png(data: RunData, path: Path) -> Path:
    """Uptime per aMussel (eq. 3); hatched: never collected; a cross above: depleted for a while."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    many = data.ids.size > 40  # thin bars: no numbers in them, every 5th id on the axis
    fig, ax = figure(min(max(8.0, 0.35 * data.ids.size), 14.0), 4.4)
    grid(ax)
    x = np.arange(data.ids.size)
    apads = sorted({m.apad for m in data.mussels})
    colour_of = {a: apad_colour(a) if data.swarm else palette()[0] for a in apads}
    for k, m in enumerate(data.mussels):
        colour = colour_of[m.apad]
        if m.never_collected:
            ax.bar(k, m.uptime_pct, color="white", edgecolor=colour, hatch="///", lw=1.2)
        else:
            ax.bar(k, m.uptime_pct, color=colour)
        if m.depleted:
            ax.plot(k, m.uptime_pct + 5, "X", color=BLACK, ms=8)
            ax.annotate(f"{m.depleted_s / 60:.0f} min", (k, m.uptime_pct + 9), ha="center", fontsize=6)
        if not many:
            ax.annotate(f"{m.dockings}", (k, 2), ha="center", fontsize=8, fontweight="bold",
                        color=ink(colour) if not m.never_collected else BLACK)
    avg = data.indices.avg_uptime_pct
    ax.axhline(avg, color=palette()[6], ls="--", lw=1.2)
    handles: list[Artist] = [Patch(color=colour_of[a], label=f"aPad {a}'s share" if data.swarm else "collected")
                             for a in apads]
    handles += [Patch(facecolor="white", edgecolor=BLACK, hatch="///", label="never collected"),
                Line2D([], [], color=BLACK, marker="X", ls="", label="depleted (minutes)"),
                Line2D([], [], color=palette()[6], ls="--", label=f"average {avg:.1f} %")]
    ax.legend(handles=handles, fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.5))
    ticks = x[::5] if many else x
    ax.set_xticks(ticks, [str(data.ids[k]) for k in ticks], fontsize=7 if data.ids.size > 30 else 9)
    never = [m.id for m in data.mussels if m.never_collected]
    flat = [m.id for m in data.mussels if m.depleted]
    ax.set(xlabel="aMussel id" if many else "aMussel id (number in the bar: dockings)",
           ylabel="uptime [% of mission steps active]", ylim=(0, 118),
           title=f"Uptime per aMussel (eq. 3) — {data.title}")
    ax.text(0.01, 0.98, f"never collected: {_ids(never)}    depleted: {_ids(flat)}", transform=ax.transAxes,
            va="top", fontsize=8)
    return save(fig, path)


def phases_png(data: RunData, path: Path) -> Path | None:
    """Where each aPad's time went: by the loop's phase (result.json's per-aPad `phase_s`) and, for
    newer runs, by what the aPad was doing (travelling, docking, holding shares). None without either."""
    apads = [a for a in as_list(data.result.get("apads")) if isinstance(a, dict) and isinstance(a.get("phase_s"), dict)]
    if not apads:
        return None
    panels = [{p: float(a["phase_s"].get(p, 0.0)) / 60.0 for p in dict.fromkeys(p for b in apads for p in b["phase_s"])}
              for a in apads]
    titles = ["by the loop's phase"]
    activity = [a for a in apads if all(k in a for k in APAD_SHARES)]
    groups = [panels]
    if len(activity) == len(apads):
        groups.append([{k.removesuffix("_share"): float(a[k]) * data.end_s / 60.0 for k in APAD_SHARES}
                       for a in apads])
        titles.append("by what the aPad was doing")
    fig, axes = figure(8.0, (1.0 + 0.45 * len(apads)) * len(groups) + 0.4, nrows=len(groups), squeeze=False)
    rows = np.arange(len(apads))
    for ax, group, title in zip(axes[:, 0], groups, titles, strict=True):
        grid(ax)
        left = np.zeros(len(apads))
        drawn = 0
        for key in group[0]:
            width = np.array([minutes_of.get(key, 0.0) for minutes_of in group])
            if width.any():  # the loop's instant phases (planning) take no time
                colour = series_style(drawn).colour
                bars = ax.barh(rows, width, left=left, color=colour, height=0.6, label=key)
                ax.bar_label(bars, [f"{w:.0f}" if w >= 2 else "" for w in width], label_type="center", fontsize=8,
                             color=ink(colour))
                drawn += 1
            left += width
        ax.set_yticks(rows, [f"aPad {a.get('sysid', k + 1)}" for k, a in enumerate(apads)])
        ax.invert_yaxis()
        ax.set_title(title, fontsize=10)
        ax.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.0, 0.5))
    axes[-1, 0].set_xlabel("minutes (the numbers in the bars)")
    fig.suptitle(f"Each aPad's time — {data.title}")
    return save(fig, path)


def _ids(ids: list[int]) -> str:
    return "none" if not ids else ", ".join(map(str, ids[:12])) + (f" (+{len(ids) - 12})" if len(ids) > 12 else "")


def _mussel_ticks(ax: Axes, data: RunData) -> None:
    step = max(data.ids.size // 30, 1)
    rows = np.arange(0, data.ids.size, step)
    ax.set_yticks(rows, [str(data.ids[r]) for r in rows], fontsize=7)
