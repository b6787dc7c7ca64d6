"""A real browser for the tests in this folder: the system's Chromium driven by Playwright.

Chromium comes from the system's package manager (`apt-get install chromium`; `.ci/run` installs
it), never from Playwright's own download (unreachable here). Without Chromium or playwright every
test here is skipped with one line saying how to install it.

`page` is a fresh page (its own context) that records what the tests check: console errors,
uncaught page errors, and every request the page made. Requests to anywhere but this machine
are recorded and then aborted, so a test offline fails on what it asked for instead of waiting.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING
from urllib.parse import urlsplit

import pytest

if TYPE_CHECKING:
    from playwright.sync_api import Browser, Page

INSTALL_HINT = ("browser tests skipped: Chromium is not installed; "
                "install it with `apt-get install chromium` (and playwright: pip install -e '.[test]')")
LOCAL_HOSTS = frozenset({"127.0.0.1", "localhost", "::1", "[::1]"})


def chromium_path() -> str | None:
    """The system's Chromium: $VIL_CHROMIUM, else chromium or chromium-browser on the PATH."""
    given = os.environ.get("VIL_CHROMIUM")
    if given:
        return given if Path(given).is_file() else None
    return shutil.which("chromium") or shutil.which("chromium-browser")


def is_local(url: str) -> bool:
    """A request that stays on this machine: a file, inline data, or a loopback address."""
    parts = urlsplit(url)
    if parts.scheme in ("file", "data", "blob", "about"):
        return True
    return parts.hostname in LOCAL_HOSTS


@dataclass
class BrowserPage:
    """A page and what it did: console errors, page errors, every request URL."""

    page: Page
    console_errors: list[str] = field(default_factory=list)
    requests: list[str] = field(default_factory=list)

    def outside_requests(self) -> list[str]:
        return [url for url in self.requests if not is_local(url)]


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    here = Path(__file__).parent
    for item in items:
        if here in item.path.parents:
            item.add_marker(pytest.mark.browser)


# One Chromium per test module, not per session: Playwright's sync API keeps an asyncio loop running
# in this thread while it is open, and the TUI tests that a worker runs next call asyncio.run().
@pytest.fixture(scope="module")
def browser() -> Iterator[Browser]:
    executable = chromium_path()
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.skip(INSTALL_HINT)
    if executable is None:
        pytest.skip(INSTALL_HINT)
    with sync_playwright() as pw:
        # --no-sandbox: the CI container runs as root, where Chromium's sandbox will not start.
        chromium = pw.chromium.launch(executable_path=executable, headless=True, args=["--no-sandbox"])
        try:
            yield chromium
        finally:
            chromium.close()


@pytest.fixture
def page(browser: Browser) -> Iterator[BrowserPage]:
    context = browser.new_context(viewport={"width": 1280, "height": 900})
    context.route(lambda url: not is_local(url), lambda route: route.abort())
    tab = context.new_page()
    seen = BrowserPage(tab)
    tab.on("console", lambda msg: seen.console_errors.append(msg.text) if msg.type == "error" else None)
    tab.on("pageerror", lambda exc: seen.console_errors.append(f"uncaught: {exc}"))
    tab.on("request", lambda request: seen.requests.append(request.url))
    try:
        yield seen
    finally:
        context.close()
