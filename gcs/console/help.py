"""The help screen: every key binding of the running console and what the map colours mean."""

from __future__ import annotations

from typing import ClassVar

from rich.console import Group
from rich.table import Table
from rich.text import Text
from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.screen import ModalScreen
from textual.widgets import Static

from gcs.console.widgets import LEGEND


class HelpScreen(ModalScreen[None]):
    BINDINGS: ClassVar[list[BindingType]] = [Binding("escape,question_mark,q", "dismiss", "Close")]

    def __init__(self, bindings: list[Binding], intro: str) -> None:
        super().__init__()
        self._key_help = bindings
        self._intro = intro

    def compose(self) -> ComposeResult:
        keys = Table.grid(padding=(0, 2))
        keys.add_column(style="bold")
        keys.add_column()
        for b in self._key_help:
            keys.add_row(b.key_display or b.key.replace("question_mark", "?"), b.description)
        body = Group(Text(self._intro + "\n"), keys, Text(""), Text.from_markup(LEGEND))
        panel = Static(body, id="help")
        panel.border_title = "Help"
        panel.border_subtitle = "esc closes"
        yield panel
