"""`vil gcs --web [HOST:]PORT`: the same console served to a browser (a tablet on deck) with textual-serve.

Each browser session runs the terminal console's own command, `vil gcs` with the same arguments
(less --web), as its own process: the same app, the same checks, the same run folder and logs.

One browser at a time. A console session is the one GCS of its mission: with --sitl a second tab
would start a second, separate mission, and with --connect a second GCS commanding the same aPads
with a loop of its own. So while a session is open, another tab is told where the console is and
gets no process. Closing that tab, or losing its connection, ends its console as closing the
terminal would (textual-serve stops a session's process with its socket); the next tab then
starts a new console, as running `vil gcs` again would.

It works with no internet: textual-serve's page links its web font from Google, so the page is
served from a copy of its template whose font is the Roboto Mono shipped inside textual-serve;
a template that still names an outside address is refused at start. Only 127.0.0.1 is bound
unless HOST says otherwise.
"""

from __future__ import annotations

import argparse
import datetime
import re
import shlex
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from aiohttp import web

DEFAULT_HOST = "127.0.0.1"
TEMPLATE = "app_index.html"
# The page's one outside asset: the stylesheet of Google's web font. Replaced by the font files
# textual-serve ships in its static folder (the same Roboto Mono); an empty icon spares the
# browser a /favicon.ico that textual-serve answers 404 (a console error).
_OUTSIDE_LINK = re.compile(r'<link[^>]*href="https?://[^"]*"[^>]*/?>', re.DOTALL)
_LOCAL_FONT = """<link rel="icon" href="data:," />
    <style>
      @font-face { font-family: "Roboto Mono"; font-style: normal;
        src: url("{{ config.static.url }}fonts/RobotoMono-VariableFont_wght.ttf") format("truetype"); }
      @font-face { font-family: "Roboto Mono"; font-style: italic;
        src: url("{{ config.static.url }}fonts/RobotoMono-Italic-VariableFont_wght.ttf") format("truetype"); }
    </style>"""
# What a browser would fetch from outside: src/href attributes and CSS url()s to http(s) addresses.
_FETCHED_OUTSIDE = re.compile(r'(?:src|href)\s*=\s*"https?://|url\(\s*["\']?https?://')


def web_address(text: str) -> tuple[str, int]:
    """[HOST:]PORT: where to serve (HOST default 127.0.0.1, this machine only)."""
    host, sep, port = text.rpartition(":")
    host = host.strip("[]") if sep else DEFAULT_HOST
    if not port.isdigit() or not 1 <= int(port) <= 65535 or (sep and not host):
        raise argparse.ArgumentTypeError(f"expected [HOST:]PORT, e.g. 8000 or 0.0.0.0:8000, got {text!r}")
    return host, int(port)


def console_command(argv: Sequence[str]) -> str:
    """The terminal console's command line for `vil gcs ARGV`: the same arguments less --web."""
    rest: list[str] = []
    skip = False
    for arg in argv:
        name = arg.split("=", 1)[0]
        if skip:
            skip = False
        elif len(name) >= 3 and "--web".startswith(name):  # --web, or argparse's abbreviations of it
            skip = "=" not in arg
        else:
            rest.append(arg)
    return shlex.join([sys.executable, "-m", "gcs.cli", *rest])


def local_template(folder: Path) -> Path:
    """textual-serve's page template with its web font served from its own static folder, written
    to `folder`; ValueError if it still names an outside address (a newer template)."""
    import textual_serve

    original = (Path(textual_serve.__file__).parent / "templates" / TEMPLATE).read_text(encoding="utf-8")
    page = _OUTSIDE_LINK.sub(lambda m: _LOCAL_FONT if "fonts.googleapis.com" in m.group(0) else m.group(0), original)
    outside = _FETCHED_OUTSIDE.search(page)
    if outside is not None:
        raise ValueError(f"textual-serve's page fetches from outside ({page[outside.start():outside.end() + 40]!r}"
                         "...): not served, it would not load offline")
    (folder / TEMPLATE).write_text(page, encoding="utf-8")
    return folder


def serve_console(argv: Sequence[str], host: str, port: int, title: str) -> int:
    """Serve `vil gcs ARGV` (less --web) on http://HOST:PORT/ until Ctrl-C; 2 if it cannot listen."""
    with tempfile.TemporaryDirectory(prefix="vil-web-") as folder:
        try:
            templates = local_template(Path(folder))
        except (OSError, ValueError) as exc:
            print(f"vil gcs: --web: {exc}", file=sys.stderr)
            return 2
        try:
            _probe(host, port)  # refused here, not after the start line said we serve
            _console_server(console_command(argv), host, port, title, templates).serve()
        except OSError as exc:
            print(f"vil gcs: --web {host}:{port}: cannot listen: {exc.strerror or exc}", file=sys.stderr)
            return 2
    return 0


def _probe(host: str, port: int) -> None:
    """OSError if nothing can listen on HOST:PORT now (in use, no such address)."""
    import socket

    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as aiohttp binds
        probe.bind((host, port))


def start_line(host: str, port: int) -> str:
    """What `vil gcs --web` says on start: the address to open, and who can reach it."""
    if host in ("0.0.0.0", "::", ""):
        where = (f"on every network of this machine: open http://<this machine's address>:{port}/ "
                 f"(here: http://127.0.0.1:{port}/)")
    elif host in ("127.0.0.1", "localhost", "::1"):
        where = f"to this machine only: open http://{host}:{port}/ (--web 0.0.0.0:{port} for the boat's network)"
    else:
        where = f"at http://{host}:{port}/"
    return f"vil gcs: serving the console {where}; one browser at a time; Ctrl+C stops"


def _console_server(command: str, host: str, port: int, title: str, templates: Path) -> Any:
    """A textual-serve `Server` for `command`: one session at a time, quiet logs, the page's
    addresses taken from the request (a tablet reaches us by an address, not by 0.0.0.0)."""
    import logging

    from textual_serve.server import Server

    class ConsoleServer(Server):
        holder: str | None = None  # who has the console now: "ADDRESS since HH:MM:SS"

        def initialize_logging(self) -> None:
            logging.basicConfig(level=logging.WARNING, format="vil gcs --web: %(message)s")

        async def on_startup(self, app: web.Application) -> None:
            print(start_line(host, port), flush=True)

        async def handle_index(self, request: web.Request) -> web.StreamResponse:
            self.public_url = f"{request.scheme}://{request.host}"
            response: web.StreamResponse = await super().handle_index(request)
            return response

        async def handle_websocket(self, request: web.Request) -> web.WebSocketResponse:
            if self.holder is not None:
                return await _refuse(request, self.holder)
            self.holder = f"{request.remote} since {datetime.datetime.now():%H:%M:%S}"
            try:
                socket: web.WebSocketResponse = await super().handle_websocket(request)
                return socket
            finally:
                self.holder = None

    return ConsoleServer(command, host=host, port=port, title=title, templates_path=templates)


async def _refuse(request: web.Request, holder: str) -> web.WebSocketResponse:
    """A second browser's session: its terminal says where the console is, and no process starts.
    The socket stays open (the page's "Session ended" dialog would hide the words) until the tab goes."""
    from aiohttp import web

    socket = web.WebSocketResponse(heartbeat=15)
    await socket.prepare(request)
    await socket.send_bytes(
        f"\r\n  The console is open in another browser ({holder}).\r\n"
        "  One browser at a time commands the mission: close it there, then reload this page.\r\n".encode())
    async for _ in socket:  # pings, resizes, keys: nothing to do with them
        pass
    return socket
