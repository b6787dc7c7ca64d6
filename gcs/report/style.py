"""The report's colours and figure plumbing, one place for every figure.

Qualitative colours are matplotlib's `petroff10` sequence (M. A. Petroff, "Accessible Color
Sequences for Data Visualization", 2021: ten colours chosen to stay apart under the common
colour-vision deficiencies). Past ten, each colour comes again with a second and a third line
style and marker, so up to 30 aMussels (or runs) each keep their own (colour, style) pair; the
id is also written beside each line or point, so nothing rests on colour alone. Continuous
values use `cividis`, built to read the same with and without colour-vision deficiency.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mussel_sim.vocabulary import MusselState

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

PALETTE_NAME = "petroff10"
SEQUENTIAL_MAP = "cividis"
LINE_STYLES = ("-", "--", ":")
MARKERS = ("o", "s", "^")
MAX_DISTINCT = 10 * len(LINE_STYLES)  # past this many series, one muted colour and no legend
GREY, BLACK = "#6b7280", "#111827"
DPI = 110

# The aMussel's states in the order their bars stack; surfacing/floating/sinking are the transit.
STATE_ORDER = (MusselState.ACTIVE, MusselState.SURFACING, MusselState.FLOATING, MusselState.DOCKED,
               MusselState.SINKING, MusselState.DEPLETED)


@dataclass(frozen=True)
class Style:
    colour: tuple[float, float, float]
    line: str
    marker: str


def palette() -> list[tuple[float, float, float]]:
    import matplotlib

    return [tuple(c) for c in matplotlib.color_sequences[PALETTE_NAME]]  # type: ignore[misc]


def series_style(k: int) -> Style:
    """The k-th series' colour, line style and marker (distinct for k < MAX_DISTINCT)."""
    colours = palette()
    group = (k // len(colours)) % len(LINE_STYLES)
    return Style(colours[k % len(colours)], LINE_STYLES[group], MARKERS[group])


def state_colours() -> dict[MusselState, tuple[float, float, float]]:
    """A colour per aMussel state: active blue, docked (charging) purple, depleted dark grey, the
    transit states yellow (surfacing), orange (floating, waiting for the aPad), cyan (sinking)."""
    c = palette()
    return {MusselState.ACTIVE: c[0], MusselState.SURFACING: c[1], MusselState.FLOATING: c[6],
            MusselState.DOCKED: c[4], MusselState.SINKING: c[9], MusselState.DEPLETED: c[8]}


def ink(colour: tuple[float, float, float]) -> str:
    """Black or white, whichever reads better on `colour` (by its relative luminance)."""
    r, g, b = colour[:3]
    return BLACK if 0.2126 * r + 0.7152 * g + 0.0722 * b > 0.45 else "white"


def apad_colour(system_id: int) -> tuple[float, float, float]:
    """An aPad keeps its colour in every figure (system ids count from 1)."""
    c = palette()
    return c[(system_id - 1) % len(c)]


def use_files_only() -> None:
    import matplotlib

    matplotlib.use("Agg")  # files only, never a window


def figure(width_in: float = 8.0, height_in: float = 4.0, **subplots: Any) -> tuple[Figure, Any]:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(width_in, height_in), dpi=DPI, layout="constrained", **subplots)
    return fig, ax


def grid(ax: Axes) -> None:
    ax.grid(True, alpha=0.3)


def legend_above(ax: Axes, handles: list[Any]) -> None:
    """The legend in one row above `ax`, off its data (a legend inside covers lines that fill the plot)."""
    ax.legend(handles=handles, loc="lower left", bbox_to_anchor=(0.0, 1.0), ncols=len(handles), fontsize=8,
              frameon=False, borderaxespad=0.2, handlelength=1.8, columnspacing=1.2)


def save(fig: Figure, path: Path) -> Path:
    import matplotlib.pyplot as plt

    fig.savefig(path)
    plt.close(fig)
    return path
