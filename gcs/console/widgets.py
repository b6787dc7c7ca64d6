"""The console's widgets. Each takes a `Snapshot` through `show()` and redraws only when it changed."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from rich.segment import Segment
from rich.style import Style
from rich.text import Text
from textual.strip import Strip
from textual.widget import Widget
from textual.widgets import DataTable, Static

from gcs.console.canvas import BrailleCanvas, scale_to
from gcs.console.model import ApadSnapshot, MarkerColour, Snapshot
from missiontime import mm_ss
from mussel_sim.geo import flat_m
from mussel_sim.vocabulary import MusselState

# Explicit hex colours: named red and magenta look alike in exports (NOTES.md).
GREEN, RED, GREY, PURPLE = "#22c55e", "#ef4444", "#9ca3af", "#c026d3"
OUTLINE, APAD, TRACE, AXIS, BLUE = "#64748b", "#facc15", "#38bdf8", "#94a3b8", "#60a5fa"
MARKER_COLOURS = {MarkerColour.CHARGED: GREEN, MarkerColour.CANDIDATE: RED,
                  MarkerColour.DEPLETED: GREY, MarkerColour.DOCKED: PURPLE}
# A swarm's aPads, in the scenario's order (the first is the one aPad's colour); none is a marker's.
APAD_COLOURS = [APAD, "#fb923c", "#2dd4bf", "#f472b6", "#a3e635", "#e2e8f0", "#818cf8", "#fda4af", "#0ea5e9"]
PALETTE = [AXIS, GREEN, RED, GREY, PURPLE, OUTLINE, APAD, TRACE, BLUE, *APAD_COLOURS[1:]]
_MARKER_INDEX = {k: PALETTE.index(v) for k, v in MARKER_COLOURS.items()}
LEGEND = (f"[{GREEN}]●[/] charged  [{RED}]●[/] pool  [{PURPLE}]●[/] docked  [{GREY}]●[/] depleted  "
          f"[{APAD}]◆[/] aPad")
SWARM_LEGEND = (f"[{GREEN}]●[/] charged  [{RED}]●[/] pool  [{PURPLE}]●[/] docked  [{GREY}]●[/] depleted  "
                f"2: aPad 2's  [{APAD}]◆[/][{APAD_COLOURS[1]}]◆[/] aPads")
AXIS_STYLE = Style(color=AXIS)


def apad_colour(snap: Snapshot, sysid: int) -> str:
    """An aPad's own colour: by its place in the scenario."""
    place = next((i for i, a in enumerate(snap.apads) if a.system_id == sysid), 0)
    return APAD_COLOURS[place % len(APAD_COLOURS)]


class CachedLines(Widget):
    """A line-API widget that draws all its strips at once, again only on new data or a new size."""

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self.snapshot: Snapshot | None = None
        self._lines: list[Strip] = []
        self._key: tuple[object, ...] = ()

    def show(self, snapshot: Snapshot) -> None:
        self.snapshot = snapshot
        self.refresh()

    def render_line(self, y: int) -> Strip:
        width, height = self.scrollable_content_region.size
        key = (id(self.snapshot), width, height)
        if key != self._key:
            self._key = key
            self._lines = self.draw(width, height) if self.snapshot is not None and width and height else []
        return self._lines[y] if y < len(self._lines) else Strip.blank(width)

    def draw(self, width: int, height: int) -> list[Strip]:
        raise NotImplementedError


class MapView(CachedLines):
    """The area in local metres, north up: outline, aMussels by class, the aPads and their traces.

    With several aPads each has its own colour, its trace drawn in it and the selected one
    highlighted; an aMussel shows the number of the aPad whose share it is, in its class colour."""

    def draw(self, width: int, height: int) -> list[Strip]:
        snap = self.snapshot
        assert snap is not None
        canvas = BrailleCanvas(width, height, PALETTE)
        swarm = len(snap.apads) > 1
        apads = snap.apads if swarm else ()
        lat = np.concatenate([snap.outline_lat_deg, snap.lat_deg, snap.trace_lat_deg,
                              [snap.apad_lat_deg if snap.apad_lat_deg is not None else np.nan],
                              *[_apad_points(a)[0] for a in apads]])
        lon = np.concatenate([snap.outline_lon_deg, snap.lon_deg, snap.trace_lon_deg,
                              [snap.apad_lon_deg if snap.apad_lon_deg is not None else np.nan],
                              *[_apad_points(a)[1] for a in apads]])
        if not np.isfinite(lat).any():
            canvas.text(1, 0, "waiting for positions", 0)
            return canvas.strips()
        lat0, lon0 = float(np.nanmean(lat)), float(np.nanmean(lon))

        def local(la: NDArray[np.float64], lo: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
            return flat_m(la, lo, lat0, lon0)

        xs, ys = local(lat, lon)
        x_lo, x_hi, y_lo, y_hi = np.nanmin(xs), np.nanmax(xs), np.nanmin(ys), np.nanmax(ys)
        # Braille dots are square: one scale (metres per dot) for both axes, with a margin.
        m_per_dot = max((x_hi - x_lo) / (canvas.dots_x - 3), (y_hi - y_lo) / (canvas.dots_y - 3), 1e-3) * 1.08
        cx, cy = (x_lo + x_hi) / 2, (y_lo + y_hi) / 2

        def dots(la: NDArray[np.float64], lo: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
            x, y = local(la, lo)
            return (x - cx) / m_per_dot + canvas.dots_x / 2, (cy - y) / m_per_dot + canvas.dots_y / 2

        canvas.polyline(*dots(snap.outline_lat_deg, snap.outline_lon_deg), PALETTE.index(OUTLINE))
        if swarm:  # the selected aPad's trace last, on top
            for a in sorted(apads, key=lambda a: a.system_id == snap.selected):
                canvas.polyline(*dots(a.trace_lat_deg, a.trace_lon_deg), PALETTE.index(apad_colour(snap, a.system_id)))
        else:
            canvas.polyline(*dots(snap.trace_lat_deg, snap.trace_lon_deg), PALETTE.index(TRACE))
        classes = snap.marker_classes()
        order = np.argsort(classes, kind="stable")  # docked and pool candidates drawn last, on top
        colours = np.array([_MARKER_INDEX[int(c)] for c in classes[order]], np.int16)
        mx, my = dots(snap.lat_deg[order], snap.lon_deg[order])
        if swarm and snap.owner.size == snap.mussel_ids.size:
            owners = snap.owner[order]
            canvas.glyphs(mx, my, np.array([str(o % 10) if o else "●" for o in owners], object), colours)
        else:
            canvas.glyphs(mx, my, "●", colours)
        if swarm:
            for a in sorted(apads, key=lambda a: a.system_id == snap.selected):
                if a.lat_deg is not None and a.lon_deg is not None:
                    ax, ay = dots(np.array([a.lat_deg]), np.array([a.lon_deg]))
                    canvas.glyphs(ax, ay, "◆", PALETTE.index(apad_colour(snap, a.system_id)),
                                  strong=a.system_id == snap.selected)
            self.border_subtitle = SWARM_LEGEND
        elif snap.apad_lat_deg is not None and snap.apad_lon_deg is not None:
            ax, ay = dots(np.array([snap.apad_lat_deg]), np.array([snap.apad_lon_deg]))
            canvas.glyphs(ax, ay, "◆", PALETTE.index(APAD))
        self.border_title = f"Map  {2 * m_per_dot:.2g} m per column"
        return canvas.strips()


def _apad_points(a: ApadSnapshot) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """An aPad's trace and position, for the map's extent."""
    here_lat = np.array([np.nan if a.lat_deg is None else a.lat_deg])
    here_lon = np.array([np.nan if a.lon_deg is None else a.lon_deg])
    return np.concatenate([a.trace_lat_deg, here_lat]), np.concatenate([a.trace_lon_deg, here_lon])


class Chart(CachedLines):
    """Time on x (mission minutes, over the whole mission), one quantity on y, labelled gutter."""

    GUTTER = 5

    def __init__(self, quantity: str, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self.quantity = quantity

    def draw(self, width: int, height: int) -> list[Strip]:
        snap = self.snapshot
        assert snap is not None
        plot_w, plot_h = max(width - self.GUTTER, 1), max(height - 1, 1)
        canvas = BrailleCanvas(plot_w, plot_h, PALETTE)
        t = snap.hist_t_s
        t_hi = max(snap.duration_s, float(t[-1]) if t.size else 0.0, 1.0)
        labels = self._plot(canvas, snap, t_hi)
        gutter = [f"{labels[0]:>{self.GUTTER - 1}} ", *[" " * self.GUTTER] * (plot_h - 2),
                  f"{labels[1]:>{self.GUTTER - 1}} "][:plot_h]
        axis = f"0{mm_ss(t_hi / 2):^{max(plot_w - 6, 0)}}{mm_ss(t_hi):>5}"[:plot_w]
        lines = []
        for label, strip in zip(gutter, canvas.strips(), strict=False):
            lines.append(Strip.join([Strip([Segment(label, AXIS_STYLE)], self.GUTTER), strip]))
        lines.append(Strip([Segment(f"{' ' * self.GUTTER}{axis:<{plot_w}}", AXIS_STYLE)], width))
        return lines

    def _x(self, canvas: BrailleCanvas, t: NDArray[np.float64], t_hi: float) -> NDArray[np.float64]:
        return scale_to(t, 0.0, t_hi, canvas.dots_x)

    def _plot(self, canvas: BrailleCanvas, snap: Snapshot, t_hi: float) -> tuple[str, str]:
        t = snap.hist_t_s
        x = self._x(canvas, t, t_hi)
        # One point per dot column at most: decimate long histories before drawing.
        step = max(int(t.size // max(canvas.dots_x, 1)), 1)
        sel = slice(None, None, step)
        if self.quantity == "battery":
            y_of = lambda v: scale_to(v, 0.0, 100.0, canvas.dots_y, flip=True)  # noqa: E731
            dashes = np.arange(0, canvas.dots_x, 3, dtype=np.float64)  # the pool threshold, dotted
            canvas.dots(dashes, np.full_like(dashes, y_of(np.array([100 * snap.pool_threshold]))[0]),
                        PALETTE.index(OUTLINE))
            hist = 100.0 * snap.hist_battery[sel].astype(np.float64)
            if hist.shape[1] <= 24:
                classes = snap.marker_classes()
                for col in np.argsort(classes, kind="stable"):
                    canvas.polyline(x[sel], y_of(hist[:, col]), _MARKER_INDEX[int(classes[col])])
            elif hist.size:
                with np.errstate(all="ignore"):
                    for series, colour in ((np.nanmin(hist, 1), RED), (np.nanmax(hist, 1), GREEN),
                                           (np.nanmean(hist, 1), BLUE)):
                        canvas.polyline(x[sel], y_of(series), PALETTE.index(colour))
            return "100%", "0%"
        if self.quantity == "active":
            n = max(snap.mussel_ids.size, 1)
            canvas.polyline(x[sel], scale_to(snap.hist_active[sel].astype(np.float64), 0, n, canvas.dots_y, True),
                            PALETTE.index(GREEN))
            return str(n), "0"
        v = snap.hist_apad_v[sel]
        lo, hi = 10.5, 16.0  # the aPad pack, empty to full
        colour = apad_colour(snap, snap.selected)  # the selected aPad's
        canvas.polyline(x[sel], scale_to(v, lo, hi, canvas.dots_y, True), PALETTE.index(colour))
        return f"{hi:g}V", f"{lo:g}V"


STATE_NAMES = {int(s): s.name.lower() for s in MusselState}


class FleetTable(DataTable[Text | str]):
    """id, state, battery, uptime; rebuilt once per new sample, keeping the cursor."""

    def on_mount(self) -> None:
        self.cursor_type = "row"
        self.zebra_stripes = True
        # Fixed widths: auto-width columns measure every cell of every rebuild (most of a frame at 200 rows).
        for label, key, width in (("id", "id", 5), ("state", "state", 9), ("battery %", "battery", 9),
                                  ("uptime %", "uptime", 8)):
            self.add_column(label, key=key, width=width)
        self._shown: tuple[object, ...] = ()

    def show(self, snap: Snapshot) -> None:
        key = (snap.hist_t_s.size, snap.mussel_ids.size, snap.state.tobytes())
        if key == self._shown:
            return
        self._shown = key
        classes = snap.marker_classes()
        rows = []
        for i in range(snap.mussel_ids.size):
            colour = MARKER_COLOURS[int(classes[i])]
            battery = snap.battery_frac[i]
            rows.append((
                str(int(snap.mussel_ids[i])),
                Text(STATE_NAMES.get(int(snap.state[i]), "?"), style=colour),
                "-" if np.isnan(battery) else f"{100 * battery:5.1f}",
                f"{snap.uptime_pct[i]:5.1f}",
            ))
        cursor = self.cursor_coordinate
        self.clear()
        self.add_rows(rows)
        if rows:
            self.move_cursor(row=min(cursor.row, len(rows) - 1), animate=False)

    def selected_mussel(self) -> int | None:
        if self.row_count == 0:
            return None
        return int(str(self.get_row_at(self.cursor_row)[0]))


class StatusPanel(Static):
    """Mission time, phase, primitive, strategy, cost, aPad battery and slots, the last notice; with
    several aPads those of the selected one, its share, and a line for each other aPad."""

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
        if snap.pending_strategy and snap.pending_strategy != snap.strategy:
            t.append(f" → {snap.pending_strategy} at next plan", style=APAD)
        t.append("\nprimitive ", style=AXIS).append(snap.primitive).append(f"   mode {snap.mode}", style=AXIS)
        volts = "-" if snap.apad_battery_v is None else f"{snap.apad_battery_v:.2f} V ({snap.apad_battery_pct} %)"
        active = int(np.count_nonzero(snap.state == MusselState.ACTIVE))
        t.append("\ncost      ", style=AXIS).append(f"{snap.cost_m:.1f} m", style="bold")
        t.append(f"   cycles {snap.cycles}   active {active}/{snap.mussel_ids.size}")
        t.append("\naPad      ", style=AXIS).append(volts)
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
        self.update(t)


def _apad_line(snap: Snapshot, a: ApadSnapshot) -> Text:
    """One other aPad on one line: phase, mode, battery, slots in use, the size of its share."""
    volts = "-" if a.battery_v is None else f"{a.battery_v:.1f} V"
    used = sum(1 for s in a.slots if s.mussel_id)
    line = Text(f"◆ aPad {a.system_id} ", style=f"bold {apad_colour(snap, a.system_id)}")
    return line.append(f"{a.ended or a.phase}, {a.mode}, {volts}, slots {used}/{len(a.slots)}, share {len(a.share)}")


class EventLog(Static):
    def show(self, snap: Snapshot) -> None:
        self.update("\n".join(snap.log[-4:]))
