"""Asked before quitting a running mission with aMussels at the surface: quit now, finish first, or stay."""

from __future__ import annotations

from typing import ClassVar, Literal

from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.screen import ModalScreen
from textual.widgets import Static

QuitChoice = Literal["now", "finish", "stay"]


class ConfirmQuit(ModalScreen[QuitChoice]):
    DEFAULT_CSS = """
    ConfirmQuit { align: center middle; }
    ConfirmQuit > #confirm { width: 64; height: auto; border: thick $warning; background: $surface; padding: 1 2; }
    """
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("y,Q", "choose('now')", "Quit now"),
        Binding("f", "choose('finish')", "Finish the collection, then quit"),
        Binding("n,escape,q", "choose('stay')", "Stay"),
    ]

    def __init__(self, floating: list[int], surfacing: list[int]) -> None:
        super().__init__()
        self._floating, self._surfacing = floating, surfacing

    def compose(self) -> ComposeResult:
        lines = ["The mission is running and aMussels are at the surface."]
        if self._floating:
            lines.append(f"Floating: {', '.join(map(str, self._floating))} (quitting now sends them down).")
        if self._surfacing:
            lines.append(f"Surfacing: {', '.join(map(str, self._surfacing))} (quitting now leaves them to float:"
                         " they take no sink command before they float).")
        lines += ["", "y  quit now", "f  finish the collection in progress, then quit", "n  stay (esc)"]
        panel = Static("\n".join(lines), id="confirm")
        panel.border_title = "Quit?"
        yield panel

    def action_choose(self, choice: QuitChoice) -> None:
        self.dismiss(choice)
