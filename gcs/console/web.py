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

A token guards it as Jupyter's does. Bound to anything but loopback, a random token is made at start
and the printed address carries it (http://HOST:PORT/?token=...); one can be given instead
(--web-token-file, or $VIL_WEB_TOKEN), and a given token guards a loopback console too. With a
token, every request and websocket must show it, from any peer, this machine included: in the
query (?token=T), in an `Authorization: token T` header, or in the cookie a browser gets when it
first shows the token in its address (HttpOnly, SameSite=Strict). The page's websocket
(ws://HOST:PORT/ws?width=..&height=.., opened by textual-serve's script from the same origin)
carries that cookie in its upgrade request; the others get 403 and a line saying where the
token is. Refusals are counted and logged once per peer.
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import hmac
import ipaddress
import logging
import os
import re
import secrets
import shlex
import sys
import tempfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any
from urllib.parse import quote, urlsplit

if TYPE_CHECKING:
    from aiohttp import web
    from aiohttp.typedefs import Handler, Middleware

DEFAULT_HOST = "127.0.0.1"
TOKEN_ENV = "VIL_WEB_TOKEN"
TOKEN_BYTES = 32  # secrets.token_urlsafe(32): 43 characters, 256 bits
REFUSAL = ("403 Forbidden: this console needs its token.\n"
           "Open the address `vil gcs --web` printed when it started: it ends in /?token=...\n")
MAX_PEERS_LOGGED = 64  # refusals from more addresses than this are counted, not logged
log = logging.getLogger(__name__)
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


class WebTokenError(ValueError):
    """A token that cannot be used (one line, for exit 2)."""


def is_loopback(host: str) -> bool:
    """Only this machine can connect to HOST: 127.0.0.0/8, ::1 (also as ::ffff:127.x.x.x), "localhost"."""
    if host.lower() == "localhost":
        return True
    try:
        address = ipaddress.ip_address(host)
    except ValueError:  # a host name: whoever it resolves for may reach it
        return False
    if isinstance(address, ipaddress.IPv6Address) and address.ipv4_mapped is not None:
        address = address.ipv4_mapped
    return address.is_loopback


def token_needed(host: str, given: str | None) -> bool:
    """Whether a console bound to HOST asks every peer for a token: a given one always, else off loopback.
    Decided by the bound address alone, never by who connects (a proxy on this machine is a loopback peer)."""
    return given is not None or not is_loopback(host)


def web_token(host: str, given: str | None, new: Callable[[], str] = lambda: secrets.token_urlsafe(TOKEN_BYTES),
              ) -> str | None:
    """The token a console bound to HOST asks for: the given one, a new random one, or None (loopback, none given)."""
    if not token_needed(host, given):
        return None
    return given if given is not None else new()


def read_web_token(path: Path | None, environ: Mapping[str, str] | None = None) -> str | None:
    """The token given for --web: PATH's first line, stripped; else $VIL_WEB_TOKEN if set; else None.
    WebTokenError (one line) if PATH cannot be read, or the token is empty or not one printable word."""
    if path is not None:
        try:
            lines = path.read_text(encoding="utf-8").splitlines()
        except (OSError, UnicodeDecodeError) as exc:
            why = getattr(exc, "strerror", None) or exc
            raise WebTokenError(f"cannot read --web-token-file {path}: {why}") from None
        token, where = (lines[0].strip() if lines else ""), f"--web-token-file {path}"
        if not token:
            raise WebTokenError(f"{where}: its first line is empty (the token goes there)")
    else:
        token, where = (os.environ if environ is None else environ).get(TOKEN_ENV, "").strip(), f"${TOKEN_ENV}"
        if not token:
            return None  # unset or empty: none given (as $VIL_SIGNING_KEY)
    if not token.isprintable() or any(c.isspace() for c in token):
        raise WebTokenError(f"{where}: the token must be one word of printable characters")
    return token


def same_origin(origin: str | None, host: str) -> bool:
    """Whether a request's Origin (a browser's page that made it) is this server (`host`: HOST:PORT
    as the request names it). No Origin: not a browser's cross-site request (curl, a script). A
    cookie is sent by a page of any port of the same host (SameSite is per site): a websocket from
    another port's page would carry it, so the origin must be this very server."""
    if origin is None:
        return True
    return urlsplit(origin).netloc.lower() == host.lower()


class TokenGate:
    """The console's door when it has a token: a request passes if it shows the token in its query
    (?token=T) or an `Authorization: token T` header, or the cookie given to a browser that showed it
    in its query. Refusals are counted; each peer's first is logged (at most MAX_PEERS_LOGGED peers)."""

    def __init__(self, token: str, port: int) -> None:
        self.token = token
        self.cookie_name = f"vil-gcs-web-{port}"  # per port: browsers share a host's cookies across ports
        # Not the token itself: a digest of it, safe as a cookie value whatever the token's characters.
        self.cookie_value = hmac.new(token.encode(), b"vil gcs --web cookie", hashlib.sha256).hexdigest()
        self.refused = 0
        self.refused_peers: set[str] = set()

    def shows_token(self, text: str | None) -> bool:
        return text is not None and hmac.compare_digest(text.encode(), self.token.encode())

    def admits(self, query_token: str | None, cookie: str | None, authorization: str | None) -> bool:
        """Whether a request with this ?token=, this cookie and this Authorization header may pass."""
        scheme, _, credentials = (authorization or "").strip().partition(" ")
        return (self.shows_token(query_token)
                or (cookie is not None and hmac.compare_digest(cookie.encode(), self.cookie_value.encode()))
                or (scheme.lower() == "token" and self.shows_token(credentials.strip())))

    def count_refusal(self, peer: str) -> bool:
        """Count one refused request from PEER; True if it is to be logged (that peer's first)."""
        self.refused += 1
        if peer in self.refused_peers or len(self.refused_peers) > MAX_PEERS_LOGGED:
            return False
        self.refused_peers.add(peer)  # one past the limit stands for "and more"
        return True

    def middleware(self) -> Middleware:
        """An aiohttp middleware refusing (403, REFUSAL) what `admits` does not let pass, and giving the
        cookie to a browser that showed the token in its address."""
        from aiohttp import web

        @web.middleware
        async def check_token(request: web.Request, handler: Handler) -> web.StreamResponse:
            shown = request.query.get("token")
            admitted = self.admits(shown, request.cookies.get(self.cookie_name), request.headers.get("Authorization"))
            if not admitted or not same_origin(request.headers.get("Origin"), request.host):
                peer = request.remote or "an unknown address"
                if self.count_refusal(peer):
                    more = len(self.refused_peers) > MAX_PEERS_LOGGED
                    log.warning("refused %s without the token (%s)", peer,
                                f"more than {MAX_PEERS_LOGGED} addresses refused: the rest are counted, not logged"
                                if more else "its further refusals are counted, not logged")
                return web.Response(status=403, text=REFUSAL)
            response = await handler(request)
            if self.shows_token(shown) and not response.prepared:  # a websocket's headers are already sent
                response.set_cookie(self.cookie_name, self.cookie_value, path="/", httponly=True, samesite="Strict")
            return response

        return check_token


def console_command(argv: Sequence[str]) -> str:
    """The terminal console's command line for `vil gcs ARGV`: the same arguments less --web and
    --web-token-file."""
    rest: list[str] = []
    skip = False
    for arg in argv:
        name = arg.split("=", 1)[0]
        if skip:
            skip = False
        elif len(name) >= 3 and "--web-token-file".startswith(name):  # --web, --web-token-file, abbreviations
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


def serve_console(argv: Sequence[str], host: str, port: int, title: str, given_token: str | None = None) -> int:
    """Serve `vil gcs ARGV` (less --web) on http://HOST:PORT/ until Ctrl-C; 2 if it cannot listen.
    Behind a token (`web_token`): the given one, or a new one off loopback."""
    token = web_token(host, given_token)
    gate = TokenGate(token, port) if token is not None else None
    with tempfile.TemporaryDirectory(prefix="vil-web-") as folder:
        try:
            templates = local_template(Path(folder))
        except (OSError, ValueError) as exc:
            print(f"vil gcs: --web: {exc}", file=sys.stderr)
            return 2
        try:
            _probe(host, port)  # refused here, not after the start line said we serve
            console_server(console_command(argv), host, port, title, templates, gate).serve()
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


def console_url(host: str, port: int, token: str | None = None) -> str:
    """http://HOST:PORT/, with ?token=TOKEN when the console has one (IPv6 addresses in brackets)."""
    shown = f"[{host}]" if ":" in host else host
    return f"http://{shown}:{port}/{_token_query(token)}"


def _token_query(token: str | None) -> str:
    return f"?token={quote(token, safe='')}" if token is not None else ""


def start_line(host: str, port: int, token: str | None = None) -> str:
    """What `vil gcs --web` says on start: the address to open (with its token), and who can reach it."""
    query = _token_query(token)
    if host in ("0.0.0.0", "::", ""):
        where = (f"on every network of this machine: open http://<this machine's address>:{port}/{query} "
                 f"(here: {console_url('127.0.0.1', port, token)})")
    elif is_loopback(host):
        where = (f"to this machine only: open {console_url(host, port, token)} (--web 0.0.0.0:{port} for the "
                 "boat's network)")
    else:
        where = f"at {console_url(host, port, token)}"
    return f"vil gcs: serving the console {where}; one browser at a time; Ctrl+C stops"


def console_server(command: str, host: str, port: int, title: str, templates: Path,
                   gate: TokenGate | None = None) -> Any:
    """A textual-serve `Server` for `command`: one session at a time, quiet logs, the page's
    addresses taken from the request (a tablet reaches us by an address, not by 0.0.0.0), and
    with a `gate`, every route behind it. `make_web_app()` builds its aiohttp app (as `serve()` does)."""
    from textual_serve.server import Server

    class ConsoleServer(Server):
        holder: str | None = None  # who has the console now: "ADDRESS since HH:MM:SS"

        def initialize_logging(self) -> None:
            logging.basicConfig(level=logging.WARNING, format="vil gcs --web: %(message)s")

        async def make_web_app(self) -> web.Application:
            """textual-serve's aiohttp app, every route (page, websocket, static files, downloads) behind the gate."""
            # textual-serve 1.1.3 has no public hook to its aiohttp app before it starts: `serve()` builds
            # it with the private `Server._make_app`. This is the one place a private name of it is used.
            app: web.Application = await super()._make_app()
            if gate is not None:
                app.middlewares.append(gate.middleware())
            return app

        async def _make_app(self) -> web.Application:  # what serve() calls: see make_web_app
            return await self.make_web_app()

        async def on_startup(self, app: web.Application) -> None:
            print(start_line(host, port, None if gate is None else gate.token), flush=True)

        async def on_shutdown(self, app: web.Application) -> None:
            if gate is not None and gate.refused:
                log.warning("refused %d request(s) without the token, from %s address(es)", gate.refused,
                            f"more than {MAX_PEERS_LOGGED}" if len(gate.refused_peers) > MAX_PEERS_LOGGED
                            else len(gate.refused_peers))

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
