"""`vil gcs --web` in a real Chromium: the browser shows the live console and obeys its keys, asks
nothing of any machine but this one, a second tab gets no second console, and Q ends the session.

The screen is drawn on a canvas, so the test reads what the browser's terminal was sent: the
bytes on the page's websocket, escape sequences taken out."""

from __future__ import annotations

import re
import subprocess
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

if TYPE_CHECKING:
    from conftest import BrowserPage  # this folder's conftest: the page and what it recorded
    from playwright.sync_api import Page, WebSocket

ESCAPES = re.compile(rb"\x1b\[[0-9;?<>=]*[ -/]*[@-~]|\x1b\][^\x07\x1b]*(?:\x07|\x1b\\)|\x1b[()][0-9A-Za-z]|\x1b[=>78]")
START_TIMEOUT_S = 60.0


@dataclass
class Served:
    url: str
    port: int
    folder: Path  # the server's working directory: each session's runs/ go here
    process: subprocess.Popen[str]
    start_line: str


@pytest.fixture(scope="module")
def served(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Served]:
    import socket

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = int(probe.getsockname()[1])
    folder = tmp_path_factory.mktemp("web")
    process = subprocess.Popen([sys.executable, "-m", "gcs.cli", "gcs", "--sitl", "--web", str(port)], cwd=folder,
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, text=True)
    try:
        assert process.stdout is not None
        line = process.stdout.readline().strip()  # said once it listens
        assert line.startswith("vil gcs: serving the console"), line
        yield Served(f"http://127.0.0.1:{port}/", port, folder, process, line)
    finally:
        process.terminate()
        process.communicate(timeout=30)
    assert process.returncode == 0


@dataclass
class Terminal:
    """What one tab's terminal was sent (the screen's text, in order) and sent back (keys)."""

    tab: Page
    received: list[bytes] = field(default_factory=list)
    sent: list[str] = field(default_factory=list)

    @staticmethod
    def of(tab: Page) -> Terminal:
        term = Terminal(tab)

        def watch(ws: WebSocket) -> None:
            ws.on("framereceived", lambda p: term.received.append(p if isinstance(p, bytes) else p.encode()))
            ws.on("framesent", lambda p: term.sent.append(p if isinstance(p, str) else p.decode()))

        tab.on("websocket", watch)
        return term

    def text(self, since: int = 0) -> str:
        return ESCAPES.sub(b"", b"".join(self.received[since:])).decode("utf-8", "replace")

    def wait_for(self, what: Callable[[str], bool], since: int = 0, timeout_s: float = START_TIMEOUT_S) -> str:
        for _ in range(int(timeout_s * 10)):  # Playwright delivers events while it waits
            if what(self.text(since)):
                return self.text(since)
            self.tab.wait_for_timeout(100)
        raise AssertionError(f"not on screen after {timeout_s} s: {self.text(since)[-2000:]!r}")

    def press(self, key: str) -> int:
        """Type `key` into the terminal; the index of the first frame sent after it."""
        mark = len(self.received)
        self.tab.focus(".xterm-helper-textarea")
        self.tab.keyboard.press(key)
        return mark


def listening_hosts(port: int) -> set[str]:
    """The addresses a TCP socket on `port` listens on (Linux /proc/net/tcp; 0100007F is 127.0.0.1)."""
    hosts = set()
    for line in Path("/proc/net/tcp").read_text().splitlines()[1:]:
        local, state = line.split()[1], line.split()[3]
        address, _, hex_port = local.partition(":")
        if state == "0A" and int(hex_port, 16) == port:
            hosts.add(".".join(str(int(address[i:i + 2], 16)) for i in (6, 4, 2, 0)))
    return hosts


def test_the_browser_shows_the_live_console_obeys_a_key_and_asks_nothing_from_outside(page: BrowserPage,
                                                                                       served: Served) -> None:
    assert served.start_line.startswith(f"vil gcs: serving the console to this machine only: open {served.url} ")
    assert listening_hosts(served.port) == {"127.0.0.1"}
    term = Terminal.of(page.page)
    page.page.goto(served.url, wait_until="load")
    page.page.wait_for_selector("body.-first-byte", timeout=START_TIMEOUT_S * 1000)  # the terminal, not the intro
    screen = term.wait_for(lambda s: "battery" in s and "embedded SITL" in s and "aPad 1" in s)
    assert "PAUSED" not in screen
    after = term.press("p")
    term.wait_for(lambda s: "PAUSED" in s, since=after, timeout_s=10.0)
    assert '["stdin","p"]' in term.sent
    assert page.page.evaluate("document.fonts.check(\"16px 'Roboto Mono'\")")  # the shipped font, loaded here
    assert any(url.endswith("/static/fonts/RobotoMono-VariableFont_wght.ttf") for url in page.requests)
    assert page.outside_requests() == [] and page.console_errors == []

    # A second tab while this one holds the console: told where it is, and no second console starts.
    second = Terminal.of(page.page.context.new_page())
    second.tab.goto(served.url, wait_until="load")
    second.wait_for(lambda s: "The console is open in another browser (127.0.0.1 since" in s, timeout_s=15.0)
    assert [p.name for p in (served.folder / "runs").glob("console-*")] == ["console-pool12-run1"]
    second.tab.close()

    term.press("Q")  # quit now: the console ends, and with it this browser's session
    page.page.wait_for_selector("body.-closed", timeout=15_000)
    assert (served.folder / "runs" / "console-pool12-run1" / "events.jsonl").stat().st_size > 0
