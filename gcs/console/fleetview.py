"""The fleet table: one row per aMussel (id, state, battery, uptime, how old that knowledge is),
scrolling under a fixed header.

A line-API view over the snapshot's arrays: only the rows on screen are formatted, each into
three segments with cached styles, and a new snapshot repaints only the rows whose text
changed. (A DataTable re-measured every visible cell through Rich at each update: most of a
frame.) The cursor row is the selected aMussel (`FleetTable.Selected`).
"""

from __future__ import annotations

from functools import lru_cache
from typing import ClassVar

import numpy as np
from rich.segment import Segment
from rich.style import Style
from textual import events
from textual.binding import Binding, BindingType
from textual.geometry import Region, Size
from textual.message import Message
from textual.reactive import reactive
from textual.scroll_view import ScrollView
from textual.strip import Strip

from gcs.console.colours import MARKER_COLOURS
from gcs.view.snapshot import Snapshot, age_text
from mussel_sim.vocabulary import MusselState

STATE_NAMES = {int(s): s.name.lower() for s in MusselState}
HEADER = f"{'id':>5}  {'state':<9} {'battery %':>9} {'uptime %':>9} {'heard':>5}"
SWARM_HEADER = f"{HEADER} {'aPad':>5}"  # with several aPads: whose share each aMussel is
_STATE_AT, _STATE_END = 7, 16  # where the state column sits in a row's text
_HEARD_AT, _HEARD_END = 36, 42  # and the age of what is known of it (stale: coloured)
STALE_COLOUR = "#ff8c00"


class MusselMessage(Message):
    """An aMussel the operator chose (in the table, on the map)."""

    def __init__(self, mussel_id: int) -> None:
        super().__init__()
        self.mussel_id = mussel_id


@lru_cache(maxsize=64)
def _coloured(base: Style, colour: str) -> Style:
    return base + Style(color=colour)


class FleetTable(ScrollView, can_focus=True):
    DEFAULT_CSS = """
    FleetTable { overflow-x: hidden; }
    FleetTable > .fleet-table--header { text-style: bold; color: $text-accent; }
    FleetTable > .fleet-table--odd { background: $surface-lighten-1 20%; }
    FleetTable > .fleet-table--cursor { background: $block-cursor-blurred-background; }
    FleetTable:focus > .fleet-table--cursor { background: $block-cursor-background; text-style: bold; }
    """
    COMPONENT_CLASSES: ClassVar[set[str]] = {"fleet-table--header", "fleet-table--odd", "fleet-table--cursor"}
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("up", "move(-1)", "Up", show=False),
        Binding("down", "move(1)", "Down", show=False),
        Binding("pageup", "page(-1)", "Page up", show=False),
        Binding("pagedown", "page(1)", "Page down", show=False),
        Binding("home", "move_to(0)", "First", show=False),
        Binding("end", "move_to(-1)", "Last", show=False),
    ]

    cursor_row: reactive[int] = reactive(0, init=False)

    class Selected(MusselMessage):
        """The cursor moved to another aMussel."""

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self.snapshot: Snapshot | None = None
        self._ids = np.zeros(0, np.int64)
        self._marker_class = np.zeros(0, np.int8)
        self._texts: dict[int, tuple[str, str]] = {}  # visible row -> (text, colour) as last painted
        self._styles: dict[str, Style] | None = None

    @property
    def row_count(self) -> int:
        return int(self._ids.size)

    def selected_mussel(self) -> int | None:
        return int(self._ids[self.cursor_row]) if self.row_count else None

    def move_cursor(self, row: int, animate: bool = False) -> None:
        self.cursor_row = min(max(row, 0), max(self.row_count - 1, 0))

    def select_mussel(self, mussel_id: int) -> None:
        rows = np.flatnonzero(self._ids == mussel_id)
        if rows.size:
            self.move_cursor(int(rows[0]))

    def show(self, snap: Snapshot) -> None:
        self.snapshot = snap
        self._marker_class = snap.marker_classes()
        grew = snap.mussel_ids.size != self._ids.size
        self._ids = snap.mussel_ids
        if grew:
            self.virtual_size = Size(self.size.width, self.row_count + 1)
            self.refresh()
            if self.row_count:
                self.post_message(self.Selected(int(self._ids[min(self.cursor_row, self.row_count - 1)])))
            return
        # Only the rows on screen, and of those only the ones whose text changed, are repainted.
        top = int(self.scroll_offset.y)
        for y in range(1, self.scrollable_content_region.height):
            if self._texts.get(y) != self._row(top + y - 1):
                self.refresh(Region(0, y, self.size.width, 1))

    def _row(self, i: int) -> tuple[str, str] | None:
        snap = self.snapshot
        if snap is None or i >= snap.mussel_ids.size:
            return None
        state = int(snap.state[i])
        battery = snap.battery_frac[i]
        colour = MARKER_COLOURS[int(self._marker_class[i])]
        age = float(snap.heard_age_s[i]) if i < snap.heard_age_s.size else float("nan")
        text = (f"{int(snap.mussel_ids[i]):>5}  {STATE_NAMES.get(state, '?'):<9} "
                f"{'-' if np.isnan(battery) else f'{100 * battery:.1f}':>9} {snap.uptime_pct[i]:>9.1f}"
                f" {age_text(age):>5}")
        if len(snap.apads) > 1:
            owner = int(snap.owner[i]) if i < snap.owner.size else 0
            text += f" {owner if owner else '-':>5}"
        return text, colour

    def render_line(self, y: int) -> Strip:
        width = self.scrollable_content_region.width
        styles = self._row_styles()
        if y == 0:
            header = SWARM_HEADER if self.snapshot is not None and len(self.snapshot.apads) > 1 else HEADER
            return Strip([Segment(header.ljust(width)[:width], styles["header"])], width)
        i = int(self.scroll_offset.y) + y - 1
        row = self._row(i)
        self._texts[y] = row  # type: ignore[assignment]
        if row is None:
            return Strip.blank(width, styles["base"])
        text, colour = row
        base = styles["cursor"] if i == self.cursor_row else styles["odd"] if i % 2 else styles["base"]
        text = text.ljust(width)[:width]
        heard = _coloured(base, STALE_COLOUR) if text[_HEARD_AT:_HEARD_END].endswith("!") else base
        return Strip([Segment(text[:_STATE_AT], base), Segment(text[_STATE_AT:_STATE_END], _coloured(base, colour)),
                      Segment(text[_STATE_END:_HEARD_AT], base), Segment(text[_HEARD_AT:_HEARD_END], heard),
                      Segment(text[_HEARD_END:], base)], width)

    def _row_styles(self) -> dict[str, Style]:
        if self._styles is None:
            base = self.rich_style
            self._styles = {"base": base, **{name: base + self.get_component_rich_style(f"fleet-table--{name}")
                                             for name in ("header", "odd", "cursor")}}
        return self._styles

    def notify_style_update(self) -> None:
        super().notify_style_update()
        self._styles = None

    def on_focus(self) -> None:
        self._styles = None
        self.refresh()

    def on_blur(self) -> None:
        self._styles = None
        self.refresh()

    def on_resize(self, event: events.Resize) -> None:
        self.virtual_size = Size(event.size.width, self.row_count + 1)
        self._texts.clear()

    def watch_scroll_y(self, old: float, new: float) -> None:
        super().watch_scroll_y(old, new)
        self._texts.clear()

    def watch_cursor_row(self, old: int, new: int) -> None:
        top = int(self.scroll_offset.y)
        for row in (old, new):
            self.refresh(Region(0, row - top + 1, self.size.width, 1))
        height = self.scrollable_content_region.height - 1  # rows under the header
        if new < top:
            self.scroll_to(y=new, animate=False)
        elif height > 0 and new >= top + height:
            self.scroll_to(y=new - height + 1, animate=False)
        if self.row_count:
            self.post_message(self.Selected(int(self._ids[new])))

    def action_move(self, delta: int) -> None:
        self.move_cursor(self.cursor_row + delta)

    def action_page(self, pages: int) -> None:
        self.move_cursor(self.cursor_row + pages * max(self.scrollable_content_region.height - 2, 1))

    def action_move_to(self, row: int) -> None:
        self.move_cursor(row if row >= 0 else self.row_count - 1)

    def on_click(self, event: events.Click) -> None:
        offset = event.get_content_offset(self)
        if offset is not None and offset.y >= 1:
            self.move_cursor(int(self.scroll_offset.y) + offset.y - 1)
