"""The link bar, always on screen above everything: each link's health and, when one is lost, the
"LINK LOST" banner (red). A replay says it is a recording; nothing here says live when it is not."""

from __future__ import annotations

from collections.abc import Sequence

from rich.text import Text
from textual.widgets import Static

from gcs.console.link_health import FLEET, Level, LinkHealth, banner
from missiontime import mm_ss

GREEN, AMBER, RED, GREY = "#22c55e", "#f59e0b", "#ef4444", "#9ca3af"
LEVEL_COLOURS = {Level.OK: GREEN, Level.LATE: AMBER, Level.LOST: RED, Level.WAITING: AMBER}


def link_text(health: Sequence[LinkHealth], stalled_s: float = 0.0) -> Text:
    """One line per the links (age, loss, signing, restarts), then the banner's words if any."""
    t = Text()
    if stalled_s:
        t.append(f"NO DATA: the world thread has not answered for {stalled_s:.0f} s", style=f"bold {RED}")
        return t
    compact = len(health) > 3  # a swarm: a short entry per aPad
    for i, h in enumerate(health):
        if i:
            t.append(" │ ", style=GREY)
        colour = LEVEL_COLOURS[h.level]
        age = f"{h.age_s:.1f} s" if h.heard else ("waiting" if h.level == Level.WAITING else "never heard")
        t.append(h.name if not compact or h.name == FLEET else h.name.removeprefix("aPad "), style="bold")
        t.append(" ● ", style=colour).append(age, style=colour)
        if h.name != FLEET and not compact:
            t.append("  loss " + ("-" if h.loss_pct is None else f"{h.loss_pct:.0f} %"), style=GREY)
            t.append("  signed" if h.signing else "  unsigned", style=GREY)
        if h.restarts:
            held = f", held {' '.join(map(str, h.held_before_restart))}" if h.held_before_restart else ""
            t.append(f"  restarted {mm_ss(h.restarted_s)}{held}", style=f"bold {AMBER}")
    return t


class LinkBar(Static):
    DEFAULT_CSS = """
    LinkBar {
        dock: top;
        height: auto;
        max-height: 3;
        padding: 0 1;
        background: $boost;
    }
    LinkBar.-lost {
        background: #7f1d1d;
    }
    """

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self._shown: tuple[object, ...] = ()

    def show(self, health: Sequence[LinkHealth], stalled_s: float = 0.0) -> None:
        """Redraw if what is shown changed (ages to a tenth of a second)."""
        words = banner(health)
        key = (tuple((h.name, round(h.age_s, 1), h.level, h.loss_pct, h.restarts) for h in health), stalled_s, words)
        if key == self._shown:
            return
        self._shown = key
        text = link_text(health, stalled_s)
        if words:
            text.append("\n").append(f" {words} ", style=f"bold #ffffff on {RED}")
        self.set_class(bool(words or stalled_s), "-lost")
        self.update(text)

    def show_replay(self, source: str) -> None:
        self.update(Text(f"REPLAY of {source}: a recording, no live link", style=f"bold {AMBER}"))
