"""The map: the area north up in metres around a fixed origin (pyproj's azimuthal equidistant
frame, `mussel_sim.geo.LocalFrame`), a dotted lat/lon grid with its labels, a scale bar, the
aPads with their traces and their slots, and the aMussels by class.

A docked aMussel reports the aPad's position; it is drawn in its slot beside the aPad instead.
The aMussel selected in the fleet table is highlighted and labelled with its id; so is the one
under the mouse; a click on an aMussel picks it (`MapView.Picked`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from textual import events
from textual.strip import Strip

from gcs.console.canvas import BrailleCanvas, CachedLines
from gcs.console.colours import (
    APAD,
    GRID,
    LABEL,
    LEGEND,
    MARKER_INDEX,
    OUTLINE,
    PALETTE,
    PURPLE,
    SWARM_LEGEND,
    TRACE,
    apad_colour,
)
from gcs.console.fleetview import MusselMessage
from gcs.view.snapshot import ApadSnapshot, Snapshot
from mussel_sim.geo import LocalFrame

Floats = NDArray[np.float64]
ROWS_PER_PARALLEL, COLUMNS_PER_MERIDIAN = 10, 28  # the grid's spacing, roughly, in cells
GRID_SAMPLES = 24  # points along each grid line (a meridian is a gentle curve in the local frame)


@dataclass(frozen=True)
class Hits:
    """The cells holding an aMussel `(k,)`, its id, and where its label goes."""

    cx: NDArray[np.int64]
    cy: NDArray[np.int64]
    ids: NDArray[np.int64]
    label_x: NDArray[np.int64]

    def at(self, x: int, y: int) -> int | None:
        """The aMussel drawn at (or one cell next to) cell (x, y); the nearest wins."""
        if not self.ids.size:
            return None
        d = np.abs(self.cx - x) + 2 * np.abs(self.cy - y)  # cells are twice as tall as wide
        k = int(np.argmin(d))
        return int(self.ids[k]) if d[k] <= 1 else None


NO_HITS = Hits(*(np.zeros(0, np.int64) for _ in range(4)))


class MapView(CachedLines):
    """With several aPads each has its own colour, its trace drawn in it and the selected one
    highlighted; an aMussel shows the number of the aPad whose share it is, in its class colour."""

    class Picked(MusselMessage):
        """The operator clicked an aMussel on the map."""

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self.selected: int | None = None
        self.hover: int | None = None
        self.hits = NO_HITS
        self._frame: tuple[object, LocalFrame] | None = None
        self._outline: tuple[object, Floats, Floats] | None = None
        self._view: _View | None = None
        self._base: tuple[object, BrailleCanvas] | None = None
        self._legend = ""

    def data_key(self) -> tuple[object, ...]:
        return id(self.snapshot), self.selected, self.hover

    def select(self, mussel_id: int | None) -> None:
        if mussel_id != self.selected:
            self.selected = mussel_id
            self.redraw()

    def on_mouse_move(self, event: events.MouseMove) -> None:
        offset = event.get_content_offset(self)
        hover = None if offset is None else self.hits.at(offset.x, offset.y)
        if hover != self.hover:
            self.hover = hover
            self.redraw()

    def on_leave(self, event: events.Leave) -> None:
        if self.hover is not None:
            self.hover = None
            self.redraw()

    def on_click(self, event: events.Click) -> None:
        offset = event.get_content_offset(self)
        picked = None if offset is None else self.hits.at(offset.x, offset.y)
        if picked is not None:
            self.post_message(self.Picked(picked))

    # --- drawing -----------------------------------------------------------------------------

    def draw(self, width: int, height: int) -> list[Strip]:
        snap = self.snapshot
        assert snap is not None
        legend = SWARM_LEGEND if len(snap.apads) > 1 else LEGEND
        if legend != self._legend:
            self.border_subtitle = self._legend = legend
        frame = self._local_frame(snap)
        if frame is None:
            canvas = BrailleCanvas(width, height, PALETTE)
            canvas.text(1, 0, "waiting for positions", 0)
            self.hits = NO_HITS
            return canvas.strips()
        ox, oy = self._outline_xy(snap, frame)
        mx, my = frame.to_local(snap.lat_deg, snap.lon_deg)
        pads = [(a, *frame.to_local(*_apad_points(a))) for a in snap.apads]
        view = self._fit(frame, width, height, np.concatenate([ox, mx, *[p[1] for p in pads]]),
                         np.concatenate([oy, my, *[p[2] for p in pads]]))
        # The grid, its labels, the outline and the scale bar change only with the view.
        base_key = (view, id(snap.outline_lat_deg))
        if self._base is None or self._base[0] != base_key:
            base = BrailleCanvas(width, height, PALETTE)
            _grid(base, view)
            base.polyline(*view.dots(ox, oy), PALETTE.index(OUTLINE))
            _scale_bar(base, view.m)
            self._base = (base_key, base)
        canvas = self._base[1].copy()
        swarm = len(snap.apads) > 1
        for a, tx, ty in sorted(pads, key=lambda p: p[0].system_id == snap.selected):  # the selected on top
            colour = apad_colour(snap, a.system_id) if swarm else TRACE
            canvas.polyline(*view.dots(tx[:-1], ty[:-1]), PALETTE.index(colour))
        hits = self._markers(canvas, view, snap, mx, my)
        hits = _concat(hits, *(self._apad(canvas, view, snap, a, tx[-1], ty[-1]) for a, tx, ty in pads))
        self.hits = hits
        for mussel, strong in ((self.hover, False), (self.selected, True)):
            k = np.flatnonzero(hits.ids == mussel) if mussel is not None else np.zeros(0, np.int64)
            if k.size:
                i = int(k[0])
                if strong:
                    canvas.strong[hits.cy[i], hits.cx[i]] = True
                canvas.text(int(hits.label_x[i]), int(hits.cy[i]), str(mussel), PALETTE.index(LABEL), strong)
        return canvas.strips()

    def _fit(self, frame: LocalFrame, width: int, height: int, xs: Floats, ys: Floats) -> _View:
        """The view of the last frame while everything stays inside it and it is not far too big
        (a map that rescales with every move repaints every row); else one fitted afresh, with
        room to spare when things were leaving it."""
        ok = np.isfinite(xs) & np.isfinite(ys)
        xs, ys = (xs[ok], ys[ok]) if ok.any() else (np.zeros(1), np.zeros(1))  # nothing yet: the origin
        dots_x, dots_y = 2 * width, 4 * height
        # The top row holds the longitude labels and the bottom row the scale bar: fit between.
        fit_y = max(4 * (height - 2), 4)
        x_lo, x_hi, y_lo, y_hi = xs.min(), xs.max(), ys.min(), ys.max()
        # Braille dots are square: one scale (metres per dot) for both axes, with a margin.
        m = max((x_hi - x_lo) / (dots_x - 3), (y_hi - y_lo) / (fit_y - 3), 1e-3) * 1.08
        old = self._view
        if old is not None and (old.frame, old.dots_x, old.dots_y) == (frame, dots_x, dots_y):
            dx, dy = old.dots(xs, ys)
            inside = dx.min() >= 0 and dx.max() < dots_x and dy.min() >= 4 and dy.max() < dots_y - 4
            if inside and m > 0.6 * old.m:
                return old
            if not inside:
                m *= 1.2
        self._view = _View(frame, m, (x_lo + x_hi) / 2, (y_lo + y_hi) / 2, dots_x, dots_y)
        return self._view

    def _markers(self, canvas: BrailleCanvas, view: _View, snap: Snapshot, mx: Floats, my: Floats) -> Hits:
        """Every aMussel not in a slot, by class (docked and pool candidates drawn last, on top)."""
        in_slots = [s.mussel_id for a in snap.apads for s in a.slots if s.mussel_id]
        classes = snap.marker_classes()
        order = np.argsort(classes, kind="stable")
        order = order[~np.isin(snap.mussel_ids[order], in_slots)]
        colours = np.array([MARKER_INDEX[int(c)] for c in classes[order]], np.int16)
        dx, dy = view.dots(mx[order], my[order])
        if len(snap.apads) > 1 and snap.owner.size == snap.mussel_ids.size:
            chars = np.array([str(o % 10) if o else "●" for o in snap.owner[order]], "<U1")
            canvas.glyphs(dx, dy, chars, colours)
        else:
            canvas.glyphs(dx, dy, "●", colours)
        seen = np.isfinite(dx) & np.isfinite(dy)
        cx, cy = (dx[seen] // 2).astype(np.int64), (dy[seen] // 4).astype(np.int64)
        label_x = np.where(cx + 4 < canvas.width, cx + 1, cx - 3)
        return Hits(cx, cy, snap.mussel_ids[order][seen], label_x)

    def _apad(self, canvas: BrailleCanvas, view: _View, snap: Snapshot, a: ApadSnapshot,
              x: float, y: float) -> Hits:
        """The aPad and its slots beside it: ● a docked aMussel, ○ an empty slot."""
        if not (math.isfinite(x) and math.isfinite(y)):
            return NO_HITS
        dx, dy = view.dots(np.array([x]), np.array([y]))
        swarm = len(snap.apads) > 1
        colour = apad_colour(snap, a.system_id) if swarm else APAD
        canvas.glyphs(dx, dy, "◆", PALETTE.index(colour), strong=swarm and a.system_id == snap.selected)
        cx, cy, n = int(dx[0] // 2), int(dy[0] // 4), len(a.slots)
        first = cx + 1 if cx + n + 4 < canvas.width else cx - n  # the block on the side with room
        ids = np.array([s.mussel_id for s in a.slots], np.int64)
        slot_x = np.arange(first, first + n, dtype=np.int64)
        for k in range(n):
            canvas.text(int(slot_x[k]), cy, "●" if ids[k] else "○", PALETTE.index(PURPLE if ids[k] else OUTLINE))
        label_x = first + n if first > cx else first - 3
        used = ids > 0
        return Hits(slot_x[used], np.full(int(used.sum()), cy, np.int64), ids[used],
                    np.full(int(used.sum()), label_x, np.int64))

    def _local_frame(self, snap: Snapshot) -> LocalFrame | None:
        """One origin for the session: the area's centre, or the first positions heard."""
        key: object = id(snap.outline_lat_deg) if snap.outline_lat_deg.size else "positions"
        if self._frame is not None and self._frame[0] in (key, "positions"):
            return self._frame[1]
        lat = snap.outline_lat_deg if snap.outline_lat_deg.size else np.concatenate(
            [snap.lat_deg, *[_apad_points(a)[0] for a in snap.apads]])
        lon = snap.outline_lon_deg if snap.outline_lon_deg.size else np.concatenate(
            [snap.lon_deg, *[_apad_points(a)[1] for a in snap.apads]])
        if not np.isfinite(lat).any():
            return None
        self._frame = (key, LocalFrame(float(np.nanmean(lat)), float(np.nanmean(lon))))
        return self._frame[1]

    def _outline_xy(self, snap: Snapshot, frame: LocalFrame) -> tuple[Floats, Floats]:
        key = (id(snap.outline_lat_deg), id(frame))
        if self._outline is None or self._outline[0] != key:
            self._outline = (key, *frame.to_local(snap.outline_lat_deg, snap.outline_lon_deg))
        return self._outline[1], self._outline[2]


@dataclass(frozen=True)
class _View:
    """Local metres to dot coordinates: `m` metres per dot, (cx, cy) at the centre."""

    frame: LocalFrame
    m: float
    cx: float
    cy: float
    dots_x: int
    dots_y: int

    def dots(self, x: Floats, y: Floats) -> tuple[Floats, Floats]:
        return (x - self.cx) / self.m + self.dots_x / 2, (self.cy - y) / self.m + self.dots_y / 2

    def metres(self, dx: Floats, dy: Floats) -> tuple[Floats, Floats]:
        return (dx - self.dots_x / 2) * self.m + self.cx, self.cy - (dy - self.dots_y / 2) * self.m


def _grid(canvas: BrailleCanvas, view: _View) -> None:
    """Dotted parallels and meridians at a round step, labelled in decimal degrees on the left
    edge (latitude) and along the top row (longitude)."""
    edge_x = np.array([0.0, canvas.dots_x / 2, canvas.dots_x, 0.0, canvas.dots_x, 0.0, canvas.dots_x / 2,
                       canvas.dots_x])
    edge_y = np.array([0.0, 0.0, 0.0, canvas.dots_y / 2, canvas.dots_y / 2, canvas.dots_y, canvas.dots_y,
                       canvas.dots_y])
    lat, lon = view.frame.to_geodetic(*view.metres(edge_x, edge_y))
    lat_lo, lat_hi, lon_lo, lon_hi = lat.min(), lat.max(), lon.min(), lon.max()
    colour, label = PALETTE.index(GRID), PALETTE.index(LABEL)
    lats, decimals = _steps(lat_lo, lat_hi, canvas.height / ROWS_PER_PARALLEL)
    dx, dy = _lines(view, lats, np.linspace(lon_lo, lon_hi, GRID_SAMPLES), parallels=True)
    canvas.polyline(dx, dy, colour, every=3)
    for value, row in zip(lats, (dy[:: GRID_SAMPLES + 1] // 4).astype(int).tolist(), strict=True):
        if 1 <= row < canvas.height - 1:
            canvas.text(0, row, _degrees(value, decimals, "NS"), label)
    lons, decimals = _steps(lon_lo, lon_hi, canvas.width / COLUMNS_PER_MERIDIAN)
    dx, dy = _lines(view, lons, np.linspace(lat_lo, lat_hi, GRID_SAMPLES), parallels=False)
    canvas.polyline(dx, dy, colour, every=3)
    end = -1
    for value, top in zip(lons, dx[GRID_SAMPLES - 1 :: GRID_SAMPLES + 1].tolist(), strict=True):
        text = _degrees(value, decimals, "EW")
        start = int(top // 2) - len(text) // 2
        if start > end and start >= 0 and start + len(text) <= canvas.width:
            canvas.text(start, 0, text, label)
            end = start + len(text)


def _steps(lo: float, hi: float, count: float) -> tuple[Floats, int]:
    """Round values between lo and hi, about `count` of them, and the decimals their step needs."""
    step = _nice(max(hi - lo, 1e-9) / max(count, 1.0), up=True)
    return np.arange(math.ceil(lo / step) * step, hi, step), max(0, math.ceil(-math.log10(step) - 1e-6))


def _lines(view: _View, values: Floats, along: Floats, parallels: bool) -> tuple[Floats, Floats]:
    """Parallels (or meridians) at `values`, sampled at `along`, in dots; one NaN between lines."""
    k, n = values.size, along.size
    fixed = np.column_stack([np.repeat(values, n).reshape(k, n), np.full(k, np.nan)]).ravel()
    moving = np.column_stack([np.tile(along, (k, 1)), np.full(k, np.nan)]).ravel()
    lat, lon = (fixed, moving) if parallels else (moving, fixed)
    return view.dots(*view.frame.to_local(lat, lon))


def _scale_bar(canvas: BrailleCanvas, m_per_dot: float) -> None:
    """A bar of a round length, about a quarter of the width, at the bottom left: |____| 5 m."""
    length_m = _nice(canvas.dots_x * m_per_dot / 4, up=False)
    x0, x1, y = 2.0, 2.0 + length_m / m_per_dot, canvas.dots_y - 1.0
    colour = PALETTE.index(LABEL)
    canvas.polyline([x0, x1], [y, y], colour)
    canvas.dots([x0, x0, x1, x1], [y - 1, y - 2, y - 1, y - 2], colour)
    canvas.text(int(x1 // 2) + 2, canvas.height - 1, f"{length_m:g} m", colour)


def _nice(value: float, up: bool) -> float:
    """The round number (1, 2 or 5 times a power of ten) just above (`up`) or below `value`."""
    power = 10.0 ** math.floor(math.log10(value))
    steps = [m * power for m in (1.0, 2.0, 5.0, 10.0)]
    return next(s for s in steps if s >= value) if up else max(s for s in steps if s <= value)


def _degrees(value: float, decimals: int, hemispheres: str) -> str:
    """Decimal degrees and the hemisphere."""
    return f"{abs(value):.{decimals}f}°{hemispheres[0] if value >= 0 else hemispheres[1]}"


def _concat(*hits: Hits) -> Hits:
    return Hits(*(np.concatenate([getattr(h, f) for h in hits]) for f in ("cx", "cy", "ids", "label_x")))


def _apad_points(a: ApadSnapshot) -> tuple[Floats, Floats]:
    """An aPad's trace, then its position (NaN when unknown)."""
    here_lat = np.array([np.nan if a.lat_deg is None else a.lat_deg])
    here_lon = np.array([np.nan if a.lon_deg is None else a.lon_deg])
    return np.concatenate([a.trace_lat_deg, here_lat]), np.concatenate([a.trace_lon_deg, here_lon])
