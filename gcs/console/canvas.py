"""A braille canvas: 2x4 dots per terminal cell, one colour per cell, optional glyphs on top.

Everything is numpy over the whole grid, so a frame with 1,000 markers costs about as much as
one with 12; `strips()` turns the grid into Textual line-API strips, one per row.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray
from rich.segment import Segment
from rich.style import Style
from textual.strip import Strip

# Bit of each dot (row 0..3, column 0..1) in the Unicode braille block U+2800.
_DOT_BITS = np.array([[0x01, 0x08], [0x02, 0x10], [0x04, 0x20], [0x40, 0x80]], np.uint8)


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
        self.glyph = np.full((self.height, self.width), "", object)
        self.glyph_colour = np.zeros((self.height, self.width), np.int16)
        self.strong = np.zeros((self.height, self.width), bool)  # glyphs drawn bold and reversed

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

    def polyline(self, x: ArrayLike, y: ArrayLike, colour: int) -> None:
        """Connect consecutive points; a NaN breaks the line."""
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
        self.dots(x0[seg] + frac * (x1 - x0)[seg], y0[seg] + frac * (y1 - y0)[seg], colour)
        self.dots(xs[-1:], ys[-1:], colour)

    def glyphs(self, x: ArrayLike, y: ArrayLike, char: str | ArrayLike, colours: ArrayLike,
               strong: bool = False) -> None:
        """Put `char` (one, or one per point) in the cells holding dot coordinates (x, y); later
        points win a shared cell. `strong`: highlighted (the selected aPad)."""
        xf, yf = np.asarray(x, np.float64).ravel(), np.asarray(y, np.float64).ravel()
        col = np.broadcast_to(np.asarray(colours, np.int16), xf.shape)
        chars = np.broadcast_to(np.asarray(char, object), xf.shape)
        ok = np.isfinite(xf) & np.isfinite(yf)
        cx, cy = np.floor(xf[ok] / 2).astype(np.int64), np.floor(yf[ok] / 4).astype(np.int64)
        inside = (cx >= 0) & (cx < self.width) & (cy >= 0) & (cy < self.height)
        cx, cy, col = cx[inside], cy[inside], col[ok][inside]
        self.glyph[cy, cx] = chars[ok][inside]
        self.glyph_colour[cy, cx] = col
        self.strong[cy, cx] = strong

    def text(self, cx: int, cy: int, text: str, colour: int) -> None:
        for i, ch in enumerate(text):
            if 0 <= cx + i < self.width and 0 <= cy < self.height:
                self.glyph[cy, cx + i] = ch
                self.glyph_colour[cy, cx + i] = colour
                self.strong[cy, cx + i] = False

    def strips(self) -> list[Strip]:
        chars = np.vectorize(chr, otypes=[object])(0x2800 + self.bits.astype(np.int32))
        chars[self.bits == 0] = " "
        has_glyph = self.glyph != ""
        chars[has_glyph] = self.glyph[has_glyph]
        colours = np.where(has_glyph, self.glyph_colour, self.colour)
        strong = has_glyph & self.strong
        out = []
        for row in range(self.height):
            segments = []
            run_start = 0
            line_chars, line_cols, line_strong = chars[row], colours[row], strong[row]
            for col in range(1, self.width + 1):
                if col == self.width or line_cols[col] != line_cols[run_start] or (
                        line_strong[col] != line_strong[run_start]):
                    colour = self.palette[int(line_cols[run_start])]
                    style = _style(colour, bool(line_strong[run_start]))
                    segments.append(Segment("".join(line_chars[run_start:col]), style))
                    run_start = col
            out.append(Strip(segments, self.width))
        return out


def scale_to(values: NDArray[np.float64], lo: float, hi: float, size: int, flip: bool = False) -> NDArray[np.float64]:
    """Map [lo, hi] onto dot coordinates [0, size - 1] (flipped for y, which grows downwards)."""
    span = hi - lo if hi > lo else 1.0
    out = (values - lo) / span * (size - 1)
    return (size - 1) - out if flip else out
