"""A braille canvas: 2x4 dots per terminal cell, one colour per cell, optional glyphs on top.

Everything is numpy over the whole grid, so a frame with 1,000 markers costs about as much as
one with 12; `strips()` turns the grid into Textual line-API strips, one per row: the row's text
is one numpy view and a segment starts only where the colour changes, so nothing is measured.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray
from rich.segment import Segment
from rich.style import Style
from textual.geometry import Region
from textual.strip import Strip
from textual.widget import Widget

from gcs.view.snapshot import Snapshot

# Bit of each dot (row 0..3, column 0..1) in the Unicode braille block U+2800.
_DOT_BITS = np.array([[0x01, 0x08], [0x02, 0x10], [0x04, 0x20], [0x40, 0x80]], np.uint8)
ROW_CACHE_SIZE = 8192  # rows of every canvas (a 250x70 screen holds ~200 canvas rows)
_ROWS: dict[tuple[str, bytes, int], Strip] = {}  # (text, colour keys, palette) -> its strip
_BRAILLE = np.array([" ", *(chr(0x2800 + b) for b in range(1, 256))], "<U1")  # no dots: a space


@lru_cache(maxsize=256)
def _style(colour: str, strong: bool = False) -> Style:
    return Style(color=colour, bold=strong, reverse=True if strong else None)


class BrailleCanvas:
    """`width` x `height` cells; dot coordinates run x in [0, 2*width), y in [0, 4*height) from the top."""

    def __init__(self, width: int, height: int, palette: list[str]) -> None:
        self.width, self.height = max(width, 1), max(height, 1)
        self.palette = palette
        self.bits = np.zeros((self.height, self.width), np.uint8)
        self.colour = np.zeros((self.height, self.width), np.int16)
        self.glyph = np.full((self.height, self.width), "", "<U1")  # "": no glyph, the dots show
        self.glyph_colour = np.zeros((self.height, self.width), np.int16)
        self.strong = np.zeros((self.height, self.width), bool)  # glyphs drawn bold and reversed

    def copy(self) -> BrailleCanvas:
        out = BrailleCanvas.__new__(BrailleCanvas)
        out.width, out.height, out.palette = self.width, self.height, self.palette
        for name in ("bits", "colour", "glyph", "glyph_colour", "strong"):
            setattr(out, name, getattr(self, name).copy())
        return out

    @property
    def dots_x(self) -> int:
        return 2 * self.width

    @property
    def dots_y(self) -> int:
        return 4 * self.height

    def dots(self, x: ArrayLike, y: ArrayLike, colour: int) -> None:
        """Set dots (float coordinates are rounded; NaN and out-of-range points are skipped)."""
        xf, yf = np.asarray(x, np.float64).ravel(), np.asarray(y, np.float64).ravel()
        ok = np.isfinite(xf) & np.isfinite(yf)
        xi, yi = np.round(xf[ok]).astype(np.int64), np.round(yf[ok]).astype(np.int64)
        inside = (xi >= 0) & (xi < self.dots_x) & (yi >= 0) & (yi < self.dots_y)
        xi, yi = xi[inside], yi[inside]
        cy, cx = yi // 4, xi // 2
        np.bitwise_or.at(self.bits, (cy, cx), _DOT_BITS[yi % 4, xi % 2])
        self.colour[cy, cx] = colour

    def polyline(self, x: ArrayLike, y: ArrayLike, colour: int, every: int = 1) -> None:
        """Connect consecutive points; a NaN breaks the line. `every` > 1: dotted, one dot in `every`."""
        xs, ys = np.asarray(x, np.float64), np.asarray(y, np.float64)
        if xs.size < 2:
            self.dots(xs, ys, colour)
            return
        x0, y0, x1, y1 = xs[:-1], ys[:-1], xs[1:], ys[1:]
        ok = np.isfinite(x0) & np.isfinite(y0) & np.isfinite(x1) & np.isfinite(y1)
        x0, y0, x1, y1 = x0[ok], y0[ok], x1[ok], y1[ok]
        steps = np.minimum(np.maximum(np.abs(x1 - x0), np.abs(y1 - y0)).astype(np.int64) + 1, 4 * self.dots_x)
        seg = np.repeat(np.arange(x0.size), steps)
        # Position of each sample within its segment, 0..1.
        starts = np.cumsum(steps) - steps
        frac = (np.arange(seg.size) - starts[seg]) / np.maximum(steps[seg], 1)
        keep = slice(None, None, every)
        self.dots((x0[seg] + frac * (x1 - x0)[seg])[keep], (y0[seg] + frac * (y1 - y0)[seg])[keep], colour)
        if every == 1:
            self.dots(xs[-1:], ys[-1:], colour)

    def glyphs(self, x: ArrayLike, y: ArrayLike, char: str | ArrayLike, colours: ArrayLike,
               strong: bool = False) -> None:
        """Put `char` (one, or one per point) in the cells holding dot coordinates (x, y); later
        points win a shared cell. `strong`: highlighted (the selected aPad)."""
        xf, yf = np.asarray(x, np.float64).ravel(), np.asarray(y, np.float64).ravel()
        col = np.broadcast_to(np.asarray(colours, np.int16), xf.shape)
        chars = np.broadcast_to(np.asarray(char, "<U1"), xf.shape)
        ok = np.isfinite(xf) & np.isfinite(yf)
        cx, cy = np.floor(xf[ok] / 2).astype(np.int64), np.floor(yf[ok] / 4).astype(np.int64)
        inside = (cx >= 0) & (cx < self.width) & (cy >= 0) & (cy < self.height)
        cx, cy, col = cx[inside], cy[inside], col[ok][inside]
        self.glyph[cy, cx] = chars[ok][inside]
        self.glyph_colour[cy, cx] = col
        self.strong[cy, cx] = strong

    def text(self, cx: int, cy: int, text: str, colour: int, strong: bool = False) -> None:
        """`text` from cell (cx, cy) rightwards, clipped at the edges."""
        for i, ch in enumerate(text):
            if 0 <= cx + i < self.width and 0 <= cy < self.height:
                self.glyph[cy, cx + i] = ch
                self.glyph_colour[cy, cx + i] = colour
                self.strong[cy, cx + i] = strong

    def strips(self) -> list[Strip]:
        """One strip per row; a row drawn before (the same text in the same colours) is the same
        Strip object as then, so unchanged rows cost a lookup and compare equal at once."""
        has_glyph = self.glyph != ""
        chars = np.where(has_glyph, self.glyph, _BRAILLE[self.bits])
        texts = chars.view(f"<U{self.width}").ravel()  # one string per row, no copy
        key = np.where(has_glyph, self.glyph_colour, self.colour).astype(np.int32) * 2 + (has_glyph & self.strong)
        cut_rows, cut_cols = np.nonzero(key[:, 1:] != key[:, :-1])
        bounds = np.searchsorted(cut_rows, np.arange(self.height + 1)).tolist()
        cut_list = (cut_cols + 1).tolist()
        palette = id(self.palette)
        if len(_ROWS) > ROW_CACHE_SIZE:
            _ROWS.clear()
        out = []
        for row in range(self.height):
            text, keys = str(texts[row]), key[row]
            cached = (text, keys.tobytes(), palette)
            strip = _ROWS.get(cached)
            if strip is None:
                starts = [0, *cut_list[bounds[row]:bounds[row + 1]]]
                ends = [*starts[1:], self.width]
                strip = _ROWS[cached] = Strip(
                    [Segment(text[a:b], _style(self.palette[int(keys[a]) >> 1], bool(keys[a] & 1)))
                     for a, b in zip(starts, ends, strict=True)], self.width)
            out.append(strip)
        return out


def scale_to(values: NDArray[np.float64], lo: float, hi: float, size: int, flip: bool = False) -> NDArray[np.float64]:
    """Map [lo, hi] onto dot coordinates [0, size - 1] (flipped for y, which grows downwards)."""
    span = hi - lo if hi > lo else 1.0
    out = (values - lo) / span * (size - 1)
    return (size - 1) - out if flip else out


class CachedLines(Widget):
    """A line-API widget that draws all its strips at once, again only when what it draws from
    (`data_key`) or its size changed, and then repaints only the rows that differ."""

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self.snapshot: Snapshot | None = None
        self._lines: list[Strip] = []
        self._key: tuple[object, ...] = ()

    def show(self, snapshot: Snapshot) -> None:
        self.snapshot = snapshot
        self.redraw()

    def data_key(self) -> tuple[object, ...]:
        """What the drawing depends on besides the size (default: the snapshot itself)."""
        return (id(self.snapshot),)

    def redraw(self) -> None:
        """Draw now if anything changed, and repaint the rows that did; hidden: at the next render."""
        width, height = self.scrollable_content_region.size
        if not (width and height and self.display):
            return
        old = self._lines
        if not self._update(width, height):
            return
        if len(old) != len(self._lines):
            self.refresh()
            return
        changed = [y for y, (a, b) in enumerate(zip(old, self._lines, strict=True)) if a != b]
        for y0, y1 in _runs(changed):
            self.refresh(Region(0, y0, width, y1 - y0))

    def _update(self, width: int, height: int) -> bool:
        key = (*self.data_key(), width, height)
        if key == self._key:
            return False
        self._key = key
        self._lines = self.draw(width, height) if self.snapshot is not None else []
        return True

    def render_line(self, y: int) -> Strip:
        width, height = self.scrollable_content_region.size
        self._update(width, height)  # a new size (or the first render): Textual repaints it all
        return self._lines[y] if y < len(self._lines) else Strip.blank(width)

    def draw(self, width: int, height: int) -> list[Strip]:
        raise NotImplementedError


def _runs(rows: list[int]) -> list[tuple[int, int]]:
    """Consecutive row numbers as [start, stop) ranges."""
    out: list[tuple[int, int]] = []
    for y in rows:
        if out and out[-1][1] == y:
            out[-1] = (out[-1][0], y + 1)
        else:
            out.append((y, y + 1))
    return out
