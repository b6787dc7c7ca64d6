"""The console's widgets. Each takes a `Snapshot` through `show()` and repaints only what changed.

The map and the fleet table live in their own modules (`mapview`, `fleetview`); the colours in
`colours`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from rich.text import Text
from textual.app import ComposeResult
from textual.containers import HorizontalGroup
from textual.strip import Strip
from textual.widgets import Footer, Static
from textual.widgets._footer import FooterKey

from gcs.console.canvas import BrailleCanvas, CachedLines, scale_to
from gcs.console.colours import (
    APAD,
    APAD_COLOURS,
    AXIS,
    BLUE,
    GREEN,
    LEGEND,
    MARKER_COLOURS,
    MARKER_INDEX,
    OUTLINE,
    PALETTE,
    PURPLE,
    RED,
    SWARM_LEGEND,
    apad_colour,
)
from gcs.console.fleetview import FleetTable
from gcs.console.mapview import MapView
from gcs.view.snapshot import ApadSnapshot, Snapshot
from missiontime import mm_ss
from mussel_sim.vocabulary import MusselState

__all__ = ["APAD", "APAD_COLOURS", "GREEN", "LEGEND", "MARKER_COLOURS", "PURPLE", "RED", "SWARM_LEGEND",
           "Chart", "ConsoleFooter", "EventPanel", "FleetTable", "MapView", "StatusPanel"]

class Chart(CachedLines):
    """Time on x (mission minutes, over the whole mission), one quantity on y, labelled gutter."""

    GUTTER = 5

    def __init__(self, quantity: str, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self.quantity = quantity

    def data_key(self) -> tuple[object, ...]:
        """A new sample, a new fleet size, another aPad selected; the battery lines also take the classes."""
        snap = self.snapshot
        if snap is None:
            return ()
        classes = snap.marker_classes().tobytes() if self.quantity == "battery" else b""
        return snap.hist_t_s.size, snap.mussel_ids.size, snap.duration_s, snap.selected, classes

    def draw(self, width: int, height: int) -> list[Strip]:
        """One canvas for the gutter, the plot and the time axis (its rows are cached strips)."""
        snap = self.snapshot
        assert snap is not None
        canvas = BrailleCanvas(width, height, PALETTE)
        plot = _Plot(2 * self.GUTTER, max(2 * (width - self.GUTTER), 2), max(4 * (height - 1), 4))
        t = snap.hist_t_s
        t_hi = max(snap.duration_s, float(t[-1]) if t.size else 0.0, 1.0)
        top, bottom = self._plot(canvas, plot, snap, t_hi)
        axis = PALETTE.index(AXIS)
        canvas.text(0, 0, f"{top:>{self.GUTTER - 1}}", axis)
        canvas.text(0, max(height - 2, 0), f"{bottom:>{self.GUTTER - 1}}", axis)
        plot_w = width - self.GUTTER
        canvas.text(self.GUTTER, height - 1, f"0{mm_ss(t_hi / 2):^{max(plot_w - 6, 0)}}{mm_ss(t_hi):>5}"[:plot_w], axis)
        return canvas.strips()

    def _plot(self, canvas: BrailleCanvas, plot: _Plot, snap: Snapshot, t_hi: float) -> tuple[str, str]:
        t = snap.hist_t_s
        x = scale_to(t, 0.0, t_hi, plot.w) + plot.x0
        # One point per dot column at most: decimate long histories before drawing.
        step = max(int(t.size // plot.w), 1)
        sel = slice(None, None, step)
        if self.quantity == "battery":
            y_of = lambda v: scale_to(v, 0.0, 100.0, plot.h, flip=True)  # noqa: E731
            dashes = np.arange(plot.x0, plot.x0 + plot.w, 3, dtype=np.float64)  # the pool threshold, dotted
            canvas.dots(dashes, np.full_like(dashes, y_of(np.array([100 * snap.pool_threshold]))[0]),
                        PALETTE.index(OUTLINE))
            hist = 100.0 * snap.hist_battery[sel].astype(np.float64)
            if hist.shape[1] <= 24:
                classes = snap.marker_classes()
                for col in np.argsort(classes, kind="stable"):
                    canvas.polyline(x[sel], y_of(hist[:, col]), MARKER_INDEX[int(classes[col])])
            elif hist.size:
                with np.errstate(all="ignore"):
                    for series, colour in ((np.nanmin(hist, 1), RED), (np.nanmax(hist, 1), GREEN),
                                           (np.nanmean(hist, 1), BLUE)):
                        canvas.polyline(x[sel], y_of(series), PALETTE.index(colour))
            return "100%", "0%"
        if self.quantity == "active":
            n = max(snap.mussel_ids.size, 1)
            canvas.polyline(x[sel], scale_to(snap.hist_active[sel].astype(np.float64), 0, n, plot.h, True),
                            PALETTE.index(GREEN))
            return str(n), "0"
        v = snap.hist_apad_v[sel]
        lo, hi = 10.5, 16.0  # the aPad pack, empty to full
        colour = apad_colour(snap, snap.selected)  # the selected aPad's
        canvas.polyline(x[sel], scale_to(v, lo, hi, plot.h, True), PALETTE.index(colour))
        return f"{hi:g}V", f"{lo:g}V"


@dataclass(frozen=True)
class _Plot:
    """Where a chart plots, in its canvas's dots: from column x0, w wide, h tall from the top."""

    x0: int
    w: int
    h: int


class StatusPanel(Static):
    """Mission time, phase, primitive, strategy, cost, aPad battery and slots, the last notice; with
    several aPads those of the selected one, its share, and a line for each other aPad."""

    _shown: Text | None = None

    def show(self, snap: Snapshot, header: str) -> None:
        t = Text()
        t.append(f"{mm_ss(snap.t_s)} / {mm_ss(snap.duration_s)}  ", style="bold")
        t.append(header)
        if snap.paused:
            t.append("  PAUSED", style=f"bold {RED}")
        swarm = len(snap.apads) > 1
        if swarm:
            t.append(f"\n◆ aPad {snap.selected}", style=f"bold {apad_colour(snap, snap.selected)}")
            t.append(f"  selected of {len(snap.apads)} (a: next)", style=AXIS)
        t.append("\nphase     ", style=AXIS).append(snap.phase, style="bold")
        t.append("   strategy ", style=AXIS).append(snap.strategy, style="bold")
        if snap.pending_strategy and snap.pending_strategy != snap.strategy:  # a line of its own: it fits
            t.append("\nnext plan ", style=AXIS).append(f"strategy {snap.pending_strategy}", style=APAD)
        t.append("\nprimitive ", style=AXIS).append(snap.primitive)  # can be long: the mode is on the aPad line
        volts = "-" if snap.apad_battery_v is None else f"{snap.apad_battery_v:.2f} V ({snap.apad_battery_pct} %)"
        active = int(np.count_nonzero(snap.state == MusselState.ACTIVE))
        t.append("\ncost      ", style=AXIS).append(f"{snap.cost_m:.1f} m", style="bold")
        t.append(f"   cycles {snap.cycles}   active {active}/{snap.mussel_ids.size}")
        t.append("\naPad      ", style=AXIS).append(volts).append(f"   mode {snap.mode}", style=AXIS)
        t.append("\nslots    ", style=AXIS)
        for s in snap.slots:
            body = f"{s.slot}:{s.mussel_id or '-'}{'⚡' if s.charging else ''}"
            t.append(f" {body:<6}", style=PURPLE if s.mussel_id else AXIS)
        if swarm:
            share = next(a.share for a in snap.apads if a.system_id == snap.selected)
            t.append("\nshare     ", style=AXIS).append(" ".join(map(str, share)) or "-")
            for a in snap.apads:
                if a.system_id != snap.selected:
                    t.append("\n").append_text(_apad_line(snap, a))
        if snap.dropped:  # what the link refused: a stranger, a spoof or a broken sender is on the network
            t.append("\nrefused   ", style=AXIS).append(f"{snap.dropped} messages", style=f"bold {APAD}")
            t.append(f" (most: {snap.dropped_top})", style=AXIS)
        if snap.ended:
            t.append(f"\nmission ended: {snap.ended}", style=f"bold {APAD}")
        if snap.notice:
            t.append(f"\n{snap.notice}", style=APAD)
        if t != self._shown:  # the clock moves every second; the rest rarely
            self._shown = t
            self.update(t)


def _apad_line(snap: Snapshot, a: ApadSnapshot) -> Text:
    """One other aPad on one line: phase, mode, battery, slots in use, the size of its share."""
    volts = "-" if a.battery_v is None else f"{a.battery_v:.1f} V"
    used = sum(1 for s in a.slots if s.mussel_id)
    line = Text(f"◆ aPad {a.system_id} ", style=f"bold {apad_colour(snap, a.system_id)}")
    return line.append(f"{a.ended or a.phase}, {a.mode}, {volts}, slots {used}/{len(a.slots)}, share {len(a.share)}")


class EventPanel(Static):
    """The latest events, newest last; as many as fit."""

    _shown: tuple[str, ...] = ()

    def show(self, snap: Snapshot) -> None:
        lines = snap.log[-max(self.scrollable_content_region.height, 1):]
        if lines != self._shown:
            self._shown = lines
            self.update("\n".join(lines))


class ConsoleFooter(Footer):
    """The key bindings, compact, on as many rows as the width needs: every key stays visible whole."""

    def __init__(self) -> None:
        super().__init__(compact=True, show_command_palette=False)
        self._rows = 1

    def compose(self) -> ComposeResult:
        keys = [k for k in super().compose() if isinstance(k, FooterKey)]
        rows = self._rows_for(keys)
        self._rows = len(rows)
        self.styles.layout = "vertical" if self._rows > 1 else "horizontal"
        self.styles.height = self._rows
        if self._rows == 1:
            yield from keys
        else:
            for row in rows:
                yield HorizontalGroup(*row)

    def _rows_for(self, keys: list[FooterKey]) -> list[list[FooterKey]]:
        """The keys in order, a row filled before the next begins."""
        width = max(self.app.size.width - 1, 1)
        rows: list[list[FooterKey]] = [[]]
        used = 0
        for key in keys:
            need = len(key.key_display) + len(key.description) + 2  # compact: "k description "
            if rows[-1] and used + need > width:
                rows.append([])
                used = 0
            rows[-1].append(key)
            used += need
        return rows

    def on_resize(self) -> None:
        if len(self._rows_for(list(self.query(FooterKey)))) != self._rows:
            self.call_after_refresh(self.recompose)
