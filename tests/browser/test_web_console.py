"""`vil gcs --web` in a real Chromium: the browser shows the live console and obeys its keys, asks
nothing of any machine but this one, a second tab gets no second console, and Q ends the session.
Bound to every network, it asks for its token, from this machine too (the tests' traffic stays on
127.0.0.1): refused without it, the console with it, and the cookie it leaves is enough after.

The screen is drawn on a canvas, so the test reads what the browser's terminal was sent: the
bytes on the page's websocket, escape sequences taken out."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

from gcs.console.web import TOKEN_ENV

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


def serve(folder: Path, host: str) -> Iterator[Served]:
    """`vil gcs --sitl --web HOST:PORT` on a free port, run in `folder`; its page at 127.0.0.1:PORT."""
    import socket

    with socket.socket() as probe:
        probe.bind((host, 0))
        port = int(probe.getsockname()[1])
    process = subprocess.Popen([sys.executable, "-m", "gcs.cli", "gcs", "--sitl", "--web", f"{host}:{port}"],
                               cwd=folder, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                               text=True, env={k: v for k, v in os.environ.items() if k != TOKEN_ENV})
    try:
        assert process.stdout is not None
        line = process.stdout.readline().strip()  # said once it listens
        assert line.startswith("vil gcs: serving the console"), line
        yield Served(f"http://127.0.0.1:{port}/", port, folder, process, line)
    finally:
        process.terminate()
        process.communicate(timeout=30)
    assert process.returncode == 0


@pytest.fixture(scope="module")
def served(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Served]:
    yield from serve(tmp_path_factory.mktemp("web"), "127.0.0.1")


@pytest.fixture(scope="module")
def served_on_every_network(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Served]:
    yield from serve(tmp_path_factory.mktemp("web-all"), "0.0.0.0")


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


# What the browser does with a websocket to the page's own address: "open" or "refused".
OPEN_WEBSOCKET = """() => new Promise(done => {
    const ws = new WebSocket(`ws://${location.host}/ws?width=80&height=24`);
    ws.onopen = () => { ws.close(); done("open"); };
    ws.onerror = () => done("refused");
})"""


def test_on_every_network_the_console_asks_this_machine_too_for_its_token(page: BrowserPage,
                                                                          served_on_every_network: Served) -> None:
    served = served_on_every_network
    assert listening_hosts(served.port) == {"0.0.0.0"}
    found = re.search(rf"\(here: http://127\.0\.0\.1:{served.port}/\?token=([A-Za-z0-9_-]{{43,}})\)", served.start_line)
    assert found is not None, served.start_line
    token = found.group(1)
    assert f"open http://<this machine's address>:{served.port}/?token={token} " in served.start_line

    # Without it, from 127.0.0.1: the page is refused and says why, its websocket is refused, no console starts.
    stranger = page.page.context.new_page()
    reply = stranger.goto(served.url, wait_until="load")
    assert reply is not None and reply.status == 403
    assert "this console needs its token" in stranger.inner_text("body")
    assert stranger.evaluate(OPEN_WEBSOCKET) == "refused"
    assert not (served.folder / "runs").exists()
    stranger.close()

    # With it in the address: the console, and a cookie for this server that is not the token itself.
    term = Terminal.of(page.page)
    reply = page.page.goto(f"{served.url}?token={token}", wait_until="load")
    assert reply is not None and reply.status == 200
    page.page.wait_for_selector("body.-first-byte", timeout=START_TIMEOUT_S * 1000)
    term.wait_for(lambda s: "battery" in s and "embedded SITL" in s and "aPad 1" in s)
    [cookie] = page.page.context.cookies()
    assert (cookie["name"], cookie["httpOnly"], cookie["sameSite"]) == (f"vil-gcs-web-{served.port}", True, "Strict")
    assert token not in cookie["value"]

    # The cookie alone: a tab at the bare address gets the page, and its websocket passes the token check
    # (to be told the console is open in the first tab; refused by the check it would never open).
    second = Terminal.of(page.page.context.new_page())
    reply = second.tab.goto(served.url, wait_until="load")
    assert reply is not None and reply.status == 200
    second.wait_for(lambda s: "The console is open in another browser (127.0.0.1 since" in s, timeout_s=15.0)
    second.tab.close()
    assert page.outside_requests() == [] and page.console_errors == []

    term.press("Q")
    page.page.wait_for_selector("body.-closed", timeout=15_000)
