"""One run's maps, in metres east and north of a stated origin (`RunData.origin`): the aPads'
tracks over the area with the aMussels' deployment positions, and a swarm's shares of the fleet."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gcs.records.events import Event
from gcs.report.run_data import RunData
from gcs.report.style import (
    BLACK,
    DPI,
    GREY,
    MAX_DISTINCT,
    apad_colour,
    figure,
    grid,
    palette,
    save,
    series_style,
)

if TYPE_CHECKING:
    from matplotlib.axes import Axes


def origin_axes(ax: Axes, data: RunData) -> None:
    """Equal metres on both axes, labelled with where (0, 0) is."""
    ax.plot(0, 0, "+", color=BLACK, ms=12, mew=1.5, zorder=4)
    ax.set_aspect("equal", adjustable="datalim")
    grid(ax)
    ax.set(xlabel=f"east [m] of the origin +: {data.origin.text()}", ylabel="north [m] of the origin")


def _area(ax: Axes, data: RunData) -> None:
    if data.outline_lat_deg.size:
        ox, oy = data.origin.xy(data.outline_lat_deg, data.outline_lon_deg)
        ax.plot(ox, oy, color=GREY, lw=1.5, label="area")


def _starts(data: RunData) -> tuple[np.ndarray, np.ndarray]:
    lat = np.array([m.start_lat_deg for m in data.mussels])
    lon = np.array([m.start_lon_deg for m in data.mussels])
    return data.origin.xy(lat, lon)


def track_png(data: RunData, path: Path) -> Path:
    """Every aPad's track, start (circle) to end (diamond), and each aMussel where it was deployed."""
    fig, ax = figure(8.5, 5.2)
    _area(ax, data)
    for track in data.tracks:
        colour = apad_colour(track.system_id)
        tx, ty = data.origin.xy(track.lat_deg, track.lon_deg)
        ax.plot(tx, ty, color=colour, lw=1.2, alpha=0.85, label=f"aPad {track.system_id} track")
        if tx.size:
            ax.plot(tx[:1], ty[:1], "o", color=colour, mec=BLACK, ms=8)
            ax.plot(tx[-1:], ty[-1:], "D", color=colour, mec=BLACK, ms=7)
    mx, my = _starts(data)
    distinct = data.ids.size <= MAX_DISTINCT
    for c, m in enumerate(data.mussels):
        if not np.isfinite(mx[c]):
            continue
        s = series_style(c)
        # Past MAX_DISTINCT: a swarm's aMussels in their aPad's colour, one aPad's all alike.
        many = apad_colour(m.apad) if data.swarm and m.apad else palette()[3]
        ax.plot(mx[c], my[c], s.marker if distinct else "o", color=s.colour if distinct else many,
                mec=BLACK, mew=0.5, ms=7 if distinct else 4, ls="", zorder=3)
        if distinct or data.ids.size <= 60:
            ax.annotate(str(m.id), (mx[c], my[c]), textcoords="offset points", xytext=(4, 4), fontsize=7)
    ax.plot([], [], "o", color=GREY, mec=BLACK, label="aPad start")
    ax.plot([], [], "D", color=GREY, mec=BLACK, label="aPad end")
    ax.plot([], [], "o", color="white", mec=BLACK, label="aMussel (deployed)")
    origin_axes(ax, data)
    ax.set_title(f"aPad track over the area — {data.title}")
    ax.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.0, 0.5))
    return save(fig, path)


def reshares(events: tuple[Event, ...]) -> list[Event]:
    """The swarm's sharings (which aPad serves which aMussels), oldest first: each re-share, with the
    aMussels that joined it as they were first heard (an acoustic fleet: `joined` events) folded in and
    the last to join's time as `heard_until_s`; an older run's event (counts, not ids) or a damaged one is
    left out."""
    out: list[Event] = []
    for event in events:
        shares = event.fields.get("shares")
        if not (isinstance(shares, dict) and all(
                isinstance(ids, list) and all(type(m) is int for m in ids) for ids in shares.values())):
            continue
        if event.kind == "reshare":
            out.append(event)
        elif event.kind == "joined" and out:
            last: dict[str, list[int]] = out[-1].fields["shares"]
            grown = {a: sorted(set(last.get(a, [])) | set(shares.get(a, []))) for a in sorted({*last, *shares})}
            out[-1] = Event(out[-1].t_s, "reshare", {**out[-1].fields, "shares": grown, "heard_until_s": event.t_s})
    return out


def partition_png(data: RunData, path: Path) -> Path | None:
    """Several aPads: the shares of the fleet, one panel per sharing (the first, with those that
    joined it as they were heard, then the last two re-shares after an aPad was lost or came back).
    None for a one-aPad run."""
    events = reshares(data.events)
    if not events:
        return None
    import matplotlib.pyplot as plt

    mx, my = _starts(data)
    where = {m.id: k for k, m in enumerate(data.mussels)}
    panels = events[:1] + events[1:][-2:]
    fig, axes = plt.subplots(1, len(panels), figsize=(max(5.5 * len(panels), 7.5), 5.0), dpi=DPI,
                             layout="constrained", squeeze=False)
    for ax, event in zip(axes[0], panels, strict=True):
        _area(ax, data)
        shares = event.fields["shares"]
        for apad, ids in sorted(shares.items(), key=lambda kv: int(kv[0])):
            colour = apad_colour(int(apad))  # an aPad keeps its colour from panel to panel
            rows = [where[m] for m in ids if m in where]
            ax.scatter(mx[rows], my[rows], s=22, color=colour, edgecolor=BLACK, lw=0.4,
                       label=f"aPad {apad}: {len(ids)}")
            if rows:
                ax.plot(np.mean(mx[rows]), np.mean(my[rows]), "X", ms=11, color=colour, mec=BLACK)
        lost = event.fields.get("lost")
        gone = ", ".join(str(a) for a in lost) if isinstance(lost, list) else ""
        origin_axes(ax, data)
        ax.xaxis.label.set_fontsize(7)
        until = event.fields.get("heard_until_s")
        heard = f", joined as heard to {until / 60:.1f} min" if isinstance(until, float) else ""
        ax.set_title(f"t = {event.t_s / 60:.1f} min" + (f", aPad {gone} lost" if gone else "") + heard)
        ax.legend(fontsize=7, loc="best")
    fig.suptitle(f"The fleet shared among the aPads — {data.title}\n"
                 "(k-means, balanced, or each as first heard to the nearest share with room; X: share centre)")
    return save(fig, path)
