"""The console apps: one screen, two drivers.

`LiveConsole` shows a `ConsoleRunner` (the world runs in a thread of its own; keys go through
`LoopControl` and the runner's command queue, never to the API from the UI thread). Quitting is
bounded: the app leaves once the world thread has ended, or `QUIT_BOUND_S` after asking it to.
`ReplayConsole` shows a recorded run with play, pause, speed and seek. Both redraw from plain
snapshots on a 10 Hz timer, and only when the snapshot changed.
"""

from __future__ import annotations

import contextlib
import threading
import time
from dataclasses import replace
from pathlib import Path
from typing import ClassVar

from textual.app import App, ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import Horizontal, Vertical
from textual.reactive import reactive

from gcs.console.confirm import ConfirmQuit, QuitChoice
from gcs.console.help import HelpScreen
from gcs.console.linkbar import LinkBar
from gcs.console.runner import ConsoleRunner, DockMussel, GoToMussel, Hold, UndockMussel
from gcs.console.widgets import LEGEND, Chart, ConsoleFooter, EventPanel, FleetTable, MapView, StatusPanel
from gcs.records.playback import Replay
from gcs.strategies import strategy_names
from gcs.view.snapshot import Snapshot
from mussel_sim.vocabulary import MusselState

REDRAW_PERIOD_S = 0.1
# Quitting waits this long (wall time) for the world thread to hold the aPads, send the floating
# aMussels down and close its logs (it takes a few hundredths of a second when the aPads answer, at
# most about half a second when they do not). At the bound the console leaves anyway: the world
# thread is a daemon and dies with the process, so the aPads get no hold from us (each holds by
# its own GCS failsafe after 3 s without our heartbeat), the last events may be missing from
# events.jsonl, and `vil gcs` says so in one line.
QUIT_BOUND_S = 2.0
STALLED_S = 2.0  # no link status from the world thread for this long (wall time): say so


class ConsoleApp(App[None]):
    CSS_PATH = Path(__file__).with_name("console.tcss")  # absolute: subclasses live elsewhere
    HELP_INTRO = ""
    # Screen classes for console.tcss: narrow, the map gives way to the tables; short, the plots do.
    HORIZONTAL_BREAKPOINTS = [(0, "-narrow"), (96, "-wide")]  # noqa: RUF012 (Textual's own declaration)
    VERTICAL_BREAKPOINTS = [(0, "-short"), (36, "-tall")]  # noqa: RUF012

    def compose(self) -> ComposeResult:
        yield LinkBar(id="links")
        with Horizontal(id="top"):
            yield MapView(id="map")
            with Vertical(id="side"):
                yield StatusPanel(id="status")
                yield FleetTable(id="fleet")
                yield EventPanel(id="log")
        with Horizontal(id="plots"):
            yield Chart("battery", id="batteries")
            yield Chart("active", id="active")
            yield Chart("apad", id="apad-battery")
        yield ConsoleFooter()

    def on_fleet_table_selected(self, event: FleetTable.Selected) -> None:
        self.map_view.select(event.mussel_id)  # the map highlights the table's selection

    def on_map_view_picked(self, event: MapView.Picked) -> None:
        self.fleet.select_mussel(event.mussel_id)

    def on_mount(self) -> None:
        # Looked up once: a timer firing during shutdown must not query a torn-down DOM.
        self.map_view = self.query_one(MapView)
        self.link_bar = self.query_one(LinkBar)
        self.status_panel = self.query_one(StatusPanel)
        self.fleet = self.query_one(FleetTable)
        self.event_panel = self.query_one(EventPanel)
        self.charts = list(self.query(Chart))
        self.map_view.border_title = "Map"
        self.map_view.border_subtitle = LEGEND
        # Escaped brackets: Textual would read [count] as markup.
        titles = (r"aMussel battery \[%]", r"active aMussels \[count]", r"aPad battery \[V]")
        for chart, title in zip(self.charts, titles, strict=True):
            chart.border_title = title
            chart.border_subtitle = r"mission time \[mm:ss]"
        self.query_one("#log").border_title = "events"
        self._shown: Snapshot | None = None
        self.set_interval(REDRAW_PERIOD_S, self.redraw)

    def current(self) -> Snapshot | None:
        raise NotImplementedError

    def header(self) -> str:
        return ""

    def show_links(self) -> None:
        """The link bar, every tick (ages move even when nothing else does)."""

    def redraw(self) -> None:
        self.show_links()
        snap = self.current()
        if snap is None or snap is self._shown:
            return
        self._shown = snap
        self.map_view.show(snap)
        self.status_panel.show(snap, self.header())
        self.fleet.show(snap)
        self.event_panel.show(snap)
        for chart in self.charts:
            chart.show(snap)

    def action_help(self) -> None:
        shown = [b for b in self.BINDINGS if isinstance(b, Binding) and self.check_action(b.action, ()) is not False]
        self.push_screen(HelpScreen(shown, self.HELP_INTRO))


class LiveConsole(ConsoleApp):
    TITLE = "vil gcs"
    HELP_INTRO = ("Live console. The up and down arrow keys (or a click) pick the aMussel in the fleet table that g, "
                  "d and u act on. Override, go-to, dock and undock pause the loop; p resumes it. q (or ctrl+c, "
                  "ctrl+q) quits within a second, asking first if aMussels are at the surface; Q quits at once: the "
                  "aPads hold, floating aMussels sink. Top line: each link's last heartbeat (amber 1.5 s, LINK LOST "
                  "3 s), lost frames, signing, restarts.")
    SWARM_HELP = (" With several aPads, a picks the aPad these keys act on (highlighted on the map, detailed in the "
                  "panel); on the map each aMussel shows the number of the aPad whose share it is.")
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("p", "toggle_pause", "Pause/resume"),
        Binding("o", "override", "Override: hold"),
        Binding("s", "switch_strategy", "Strategy"),
        Binding("g", "goto", "Go to selected"),
        Binding("d", "dock", "Dock selected"),
        Binding("u", "undock", "Undock selected"),
        Binding("a", "next_apad", "Next aPad"),
        Binding("question_mark", "help", "Help", key_display="?"),
        Binding("q", "quit_console", "Quit"),
        Binding("Q", "quit_console(True)", "Quit now"),
    ]

    paused: reactive[bool] = reactive(False, init=False)

    def __init__(self, runner: ConsoleRunner) -> None:
        super().__init__()
        self.runner = runner
        if runner.swarm:
            self.HELP_INTRO = LiveConsole.HELP_INTRO + self.SWARM_HELP
        self.set_reactive(LiveConsole.paused, runner.control.paused)
        self.quitting = False
        self._quit_by: float | None = None  # monotonic time the app leaves at, whatever the world thread does
        self._ended_seen = False
        # The world (link, fleet, SITL, loop) lives on this one thread for the whole session. Not a
        # Textual worker: those run in asyncio's default executor, which the app's exit waits for
        # without a bound (the screen blank meanwhile).
        self.world_thread = threading.Thread(target=self._run_world, name="vil-world", daemon=True)

    def _run_world(self) -> None:
        with contextlib.suppress(Exception):  # kept in runner.error and shown: no traceback over the screen
            self.runner.run()

    def on_mount(self) -> None:
        super().on_mount()
        self.world_thread.start()

    def on_unmount(self) -> None:
        # However the app ends (q, an error, a test), the world thread must not outlive it for long.
        self.runner.request_quit(now=True)
        if self.world_thread.is_alive():
            # What is left of the bound (nothing once passed); QUIT_BOUND_S when the app ends another way.
            left = QUIT_BOUND_S if self._quit_by is None else self._quit_by - time.monotonic()
            if left > 0:
                self.world_thread.join(left)

    def current(self) -> Snapshot | None:
        return self.runner.snapshot

    def header(self) -> str:
        return self.runner.snapshot.source if self.runner.snapshot else ""

    def show_links(self) -> None:
        runner = self.runner
        stalled = time.monotonic() - runner.link_published_s if runner.link_published_s else 0.0
        alive = not runner.finished.is_set()
        self.link_bar.show(runner.link_status, stalled if alive and stalled > STALLED_S else 0.0)
        if runner.finished.is_set() and not self._ended_seen:
            self._ended_seen = True
            if self.quitting:
                self.exit()
            elif runner.error:
                self.notify(runner.error, severity="error", timeout=30)
        if self._quit_by is not None and time.monotonic() >= self._quit_by:
            self.exit()  # the bound: the world thread did not end in time (see QUIT_BOUND_S)

    def watch_paused(self, paused: bool) -> None:
        self.runner.set_paused(paused)

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        """One aPad: no aPad to pick (the footer and help do not offer it)."""
        return self.runner.swarm or action != "next_apad"

    def action_next_apad(self) -> None:
        sysid = self.runner.select_apad()
        self.notify(f"the override keys act on aPad {sysid}")

    def action_toggle_pause(self) -> None:
        self.paused = not self.runner.control.paused

    def action_override(self) -> None:
        self.runner.submit(Hold())
        self.paused = True

    def action_switch_strategy(self) -> None:
        snap = self.runner.snapshot
        names = strategy_names()  # the shipped ones, then any loaded from outside (--strategy FILE.py:FUNCTION)
        now = (snap.pending_strategy or snap.strategy) if snap else names[0]
        following = names[(names.index(now) + 1) % len(names)] if now in names else names[0]
        self.runner.switch_strategy(following)
        self.notify(f"strategy {following} from the next planning step")

    def _selected(self) -> int | None:
        mussel = self.fleet.selected_mussel()
        if mussel is None:
            self.notify("select an aMussel in the fleet table first", severity="warning")
        return mussel

    def action_goto(self) -> None:
        if (m := self._selected()) is not None:
            self.runner.submit(GoToMussel(m))
            self.paused = True

    def action_dock(self) -> None:
        if (m := self._selected()) is not None:
            self.runner.submit(DockMussel(m))
            self.paused = True

    def action_undock(self) -> None:
        if (m := self._selected()) is not None:
            self.runner.submit(UndockMussel(m))
            self.paused = True

    def action_quit_console(self, now: bool = False) -> None:
        """q: quit now, but ask first when the mission runs and aMussels are at the surface; Q: at once."""
        if self.quitting and not now:
            return
        up = self._at_surface()
        if not now and self.runner.mission_running() and any(up):
            self.push_screen(ConfirmQuit(*up), self._quit_choice)
            return
        self._quit(finish=False)

    async def action_quit(self) -> None:
        """ctrl+q (Textual's own quit key) quits as q does, bounded, never leaving a blank screen waiting."""
        self.action_quit_console()

    def action_help_quit(self) -> None:
        """ctrl+c, an operator's reflex: the quit q starts (Textual's own only says which key quits).
        While the confirm asks, it waits for its answer."""
        if not isinstance(self.screen, ConfirmQuit):
            self.action_quit_console()

    def _quit_choice(self, choice: QuitChoice | None) -> None:
        if choice == "now":
            self._quit(finish=False)
        elif choice == "finish":
            self._quit(finish=True)
        else:
            self.runner.log_operator("quit_cancelled")

    def _quit(self, finish: bool) -> None:
        """Ask the world to end; leave when it has, or at the bound (`finish`: no bound, the loop ends
        its collection first; Q still quits at once)."""
        self.quitting = True
        self.runner.request_quit(now=not finish)
        self._quit_by = None if finish else time.monotonic() + QUIT_BOUND_S
        if self.runner.finished.is_set():
            self.exit()
        else:
            self.notify("finishing the collection, then quitting (Q: now)" if finish else "quitting")

    def _at_surface(self) -> tuple[list[int], list[int]]:
        """aMussels floating and surfacing, not on a slot, as the screen shows them now."""
        snap = self.runner.snapshot
        if snap is None:
            return [], []
        on_slots = {s.mussel_id for a in snap.apads for s in a.slots if s.mussel_id}

        def those(state: MusselState) -> list[int]:
            return [int(m) for m in snap.mussel_ids[snap.state == state] if int(m) not in on_slots]

        return those(MusselState.FLOATING), those(MusselState.SURFACING)


class ReplayConsole(ConsoleApp):
    TITLE = "vil replay"
    HELP_INTRO = "Replay of a recorded run: the same screen as the live console, driven from its logs."
    BINDINGS: ClassVar[list[BindingType]] = [
        # Priority: the fleet table would take these keys for its own scrolling.
        Binding("space", "toggle_play", "Play/pause", priority=True),
        Binding("plus,equals_sign", "faster", "Faster", key_display="+"),
        Binding("minus", "slower", "Slower", key_display="-"),
        Binding("right", "seek(10)", "+10 s", priority=True),
        Binding("left", "seek(-10)", "-10 s", priority=True),
        Binding("shift+right,pagedown", "seek(60)", "+60 s", show=False, priority=True),
        Binding("shift+left,pageup", "seek(-60)", "-60 s", show=False, priority=True),
        Binding("home", "seek_to(0)", "Start", show=False, priority=True),
        Binding("end", "seek_to(-1)", "End", show=False, priority=True),
        Binding("question_mark", "help", "Help", key_display="?"),
        Binding("q", "quit", "Quit"),
    ]

    playing: reactive[bool] = reactive(True)
    speed: reactive[float] = reactive(8.0)
    position_s: reactive[float] = reactive(0.0)

    def __init__(self, replay: Replay, start_s: float = 0.0, playing: bool = True, speed: float = 8.0) -> None:
        super().__init__()
        self.replay = replay
        self.set_reactive(ReplayConsole.position_s, start_s)
        self.set_reactive(ReplayConsole.playing, playing)
        self.set_reactive(ReplayConsole.speed, speed)
        self._framed: tuple[object, ...] = ()
        self._frame: Snapshot | None = None

    def on_mount(self) -> None:
        super().on_mount()
        self.link_bar.show_replay(Path(self.replay.source).name)
        self.set_interval(REDRAW_PERIOD_S, self._advance)

    def _advance(self) -> None:
        if self.playing:
            self.position_s = min(self.position_s + REDRAW_PERIOD_S * self.speed, self.replay.end_s)
            if self.position_s >= self.replay.end_s:
                self.playing = False

    def current(self) -> Snapshot | None:
        frame = self.replay.at(self.position_s)
        key = (id(frame), self.playing, self.speed)
        if key != self._framed:  # a new object only when something shown changed
            self._framed = key
            state = "▶" if self.playing else "⏸"
            self._frame = replace(frame, notice=f"{state} {self.speed:g}x   {frame.notice}".rstrip())
        return self._frame

    def header(self) -> str:
        return f"REPLAY  {Path(self.replay.source).name}"

    def action_help_quit(self) -> None:
        """ctrl+c quits, as q does (Textual's own only says which key quits)."""
        self.exit()

    def action_toggle_play(self) -> None:
        if not self.playing and self.position_s >= self.replay.end_s:
            self.position_s = 0.0
        self.playing = not self.playing

    def action_faster(self) -> None:
        self.speed = min(self.speed * 2, 256.0)

    def action_slower(self) -> None:
        self.speed = max(self.speed / 2, 0.25)

    def action_seek(self, delta_s: float) -> None:
        self.position_s = min(max(self.position_s + delta_s, 0.0), self.replay.end_s)

    def action_seek_to(self, t_s: float) -> None:
        self.position_s = self.replay.end_s if t_s < 0 else min(t_s, self.replay.end_s)
