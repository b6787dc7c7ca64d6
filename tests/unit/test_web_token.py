"""`vil gcs --web` behind a token: when one is asked for (by the bound address alone), what passes
(query, cookie, `Authorization: token`), the served app refusing every route without it (a real
server on 127.0.0.1), and a given token that cannot be used refused before anything starts."""

from __future__ import annotations

import asyncio
import logging
import os
import shlex
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from gcs.console.web import (
    MAX_PEERS_LOGGED,
    REFUSAL,
    TOKEN_ENV,
    TokenGate,
    WebTokenError,
    console_command,
    console_server,
    local_template,
    read_web_token,
    start_line,
    token_needed,
    web_token,
)

LOOPBACK = ["127.0.0.1", "127.8.9.10", "::1", "localhost", "LocalHost", "::ffff:127.0.0.1"]
REACHABLE = ["0.0.0.0", "::", "", "192.168.1.20", "10.0.0.1", "fe80::1", "boat.local", "::ffff:192.168.1.20"]


@pytest.mark.parametrize("host", LOOPBACK)
def test_loopback_needs_no_token_unless_one_is_given(host: str) -> None:
    assert not token_needed(host, None)
    assert token_needed(host, "given")
    assert web_token(host, None, new=lambda: pytest.fail("no token is made on loopback")) is None
    assert web_token(host, "given") == "given"


@pytest.mark.parametrize("host", REACHABLE)
def test_any_other_bound_address_gets_a_new_token_or_the_given_one(host: str) -> None:
    assert token_needed(host, None) and token_needed(host, "given")
    assert web_token(host, None, new=lambda: "fresh") == "fresh"
    assert web_token(host, "given", new=lambda: pytest.fail("a given token is used")) == "given"


def test_a_new_token_is_random_and_long() -> None:
    first, second = web_token("0.0.0.0", None), web_token("0.0.0.0", None)
    assert first is not None and second is not None and first != second
    assert len(first) >= 43  # secrets.token_urlsafe(32): 256 bits


def test_a_given_token_is_the_files_first_line_else_the_environment(tmp_path: Path) -> None:
    path = tmp_path / "token"
    path.write_text("  s3cret-Token_1  \nsecond line\n")
    assert read_web_token(path, {TOKEN_ENV: "from-env"}) == "s3cret-Token_1"  # the file wins
    assert read_web_token(None, {TOKEN_ENV: " from-env\n"}) == "from-env"
    assert read_web_token(None, {TOKEN_ENV: "  "}) is None  # empty: none given, as $VIL_SIGNING_KEY
    assert read_web_token(None, {}) is None


def test_the_gate_admits_the_token_in_the_query_the_cookie_or_the_header_and_nothing_else() -> None:
    gate = TokenGate("s3cret", port=8000)
    assert gate.admits("s3cret", None, None)
    assert gate.admits(None, gate.cookie_value, None)
    assert gate.admits(None, None, "token s3cret") and gate.admits(None, None, "Token  s3cret ")
    assert gate.cookie_value != "s3cret" and gate.cookie_name == "vil-gcs-web-8000"
    for query, cookie, header in [(None, None, None), ("s3cre", None, None), ("s3cret2", None, None),
                                  ("", "", ""), (None, "s3cret", None), (None, None, "Bearer s3cret"),
                                  (None, None, "s3cret"), ("s3crét", "cookie-é", "token é")]:  # non-ASCII: no raise
        assert not gate.admits(query, cookie, header), (query, cookie, header)


def test_refusals_are_all_counted_and_each_peers_first_logged_up_to_a_bound() -> None:
    gate = TokenGate("s3cret", port=8000)
    assert [gate.count_refusal("10.0.0.1") for _ in range(3)] == [True, False, False]
    logged = [gate.count_refusal(f"10.1.{i // 256}.{i % 256}") for i in range(2 * MAX_PEERS_LOGGED)]
    assert sum(logged) == MAX_PEERS_LOGGED  # the last of them stands for "and more"
    assert gate.refused == 3 + 2 * MAX_PEERS_LOGGED and len(gate.refused_peers) == MAX_PEERS_LOGGED + 1


@pytest.mark.parametrize("argv", [
    ["gcs", "--sitl", "--web", "0.0.0.0:8000", "--web-token-file", "t.txt", "--scenario", "pool12x2"],
    ["gcs", "--web-token-file=t.txt", "--sitl", "--web=8000", "--scenario", "pool12x2"],
    ["gcs", "--sitl", "--web-t", "t.txt", "--web", "8000", "--scenario", "pool12x2"],  # an abbreviation
])
def test_each_browser_session_runs_the_console_without_the_token_file(argv: list[str]) -> None:
    assert shlex.split(console_command(argv)) == [sys.executable, "-m", "gcs.cli", "gcs", "--sitl", "--scenario",
                                                  "pool12x2"]


def test_the_start_line_carries_the_token() -> None:
    assert start_line("0.0.0.0", 8000, "a/b") == (
        "vil gcs: serving the console on every network of this machine: open http://<this machine's address>:8000/"
        "?token=a%2Fb (here: http://127.0.0.1:8000/?token=a%2Fb); one browser at a time; Ctrl+C stops")
    assert "open http://127.0.0.1:8000/?token=T (" in start_line("127.0.0.1", 8000, "T")
    assert "at http://[fe80::1]:8000/?token=T;" in start_line("fe80::1", 8000, "T")


def test_the_served_app_refuses_page_websocket_and_static_files_without_the_token(
        tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """textual-serve's own app, with the gate, served on 127.0.0.1 (no session process is started)."""
    import aiohttp
    from aiohttp import web

    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    port = listener.getsockname()[1]
    base = f"http://127.0.0.1:{port}"
    gate = TokenGate("s3cret", port)
    server = console_server("false", "127.0.0.1", port, "test", local_template(tmp_path), gate)

    async def exercise() -> None:
        runner = web.AppRunner(await server.make_web_app())
        await runner.setup()
        await web.SockSite(runner, listener).start()
        try:
            async with aiohttp.ClientSession() as http:
                for path in ("/", "/?token=wrong", "/static/css/xterm.css", "/download/x"):
                    async with http.get(base + path) as reply:
                        assert (reply.status, await reply.text()) == (403, REFUSAL), path
                with pytest.raises(aiohttp.WSServerHandshakeError) as refused:
                    await http.ws_connect(f"{base}/ws?width=80&height=24")
                assert refused.value.status == 403

                async with http.get(f"{base}/?token=s3cret") as reply:
                    assert reply.status == 200 and "data-session-websocket-url" in await reply.text()
                    cookie = reply.headers["Set-Cookie"]
                assert cookie.startswith(f"{gate.cookie_name}={gate.cookie_value};")
                assert {"HttpOnly", "Path=/", "SameSite=Strict"} <= {part.strip() for part in cookie.split(";")}
                with_cookie = {"Cookie": f"{gate.cookie_name}={gate.cookie_value}"}
                for headers in (with_cookie, {"Authorization": "token s3cret"}):
                    async with http.get(f"{base}/", headers=headers) as reply:
                        assert reply.status == 200 and "Set-Cookie" not in reply.headers, headers
                async with http.get(f"{base}/static/css/xterm.css", headers=with_cookie) as reply:
                    assert reply.status == 200
                # The page's websocket with the cookie alone: let in, and told the console is open elsewhere
                # (a holder is set so that no session process starts here).
                server.holder = "10.0.0.9 since 12:00:00"
                async with http.ws_connect(f"{base}/ws?width=80&height=24", headers=with_cookie) as ws:
                    said = await ws.receive_bytes(timeout=10)
                assert b"The console is open in another browser (10.0.0.9 since 12:00:00)" in said
        finally:
            await runner.cleanup()

    with caplog.at_level(logging.WARNING, logger="gcs.console.web"):
        asyncio.run(asyncio.wait_for(exercise(), timeout=30))  # a hang fails, and says where
    assert gate.refused == 5 and gate.refused_peers == {"127.0.0.1"}
    assert [r.getMessage() for r in caplog.records if r.name == "gcs.console.web"] == [
        "refused 127.0.0.1 without the token (its further refusals are counted, not logged)",
        "refused 5 request(s) without the token, from 1 address(es)"]  # at shutdown


def test_a_token_file_that_cannot_be_used_is_one_line_and_exit_2_before_anything_starts(tmp_path: Path) -> None:
    (tmp_path / "empty").write_text("")
    cases = {  # --web-token-file -> the line on stderr
        tmp_path / "missing": f"cannot read --web-token-file {tmp_path / 'missing'}: No such file or directory",
        tmp_path: f"cannot read --web-token-file {tmp_path}: Is a directory",
        tmp_path / "empty": f"--web-token-file {tmp_path / 'empty'}: its first line is empty (the token goes there)",
    }
    env = {k: v for k, v in os.environ.items() if k != TOKEN_ENV}
    started = {path: subprocess.Popen([sys.executable, "-m", "gcs.cli", "gcs", "--sitl", "--web", "0.0.0.0:8000",
                                       "--web-token-file", str(path)], cwd=tmp_path, env=env, stdin=subprocess.DEVNULL,
                                      stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
               for path in cases}  # side by side: each is an interpreter's start
    for path, process in started.items():
        out, err = process.communicate(timeout=60)
        assert (process.returncode, out, err) == (2, "", f"vil gcs: {cases[path]}\n"), path


def test_other_unusable_tokens_are_one_line(tmp_path: Path) -> None:
    (tmp_path / "blank-first").write_text("\ns3cret\n")
    (tmp_path / "latin1").write_bytes(b"caf\xe9\n")
    (tmp_path / "two-words").write_text("two words\n")
    with pytest.raises(WebTokenError, match=r"blank-first: its first line is empty \(the token goes there\)$"):
        read_web_token(tmp_path / "blank-first")
    with pytest.raises(WebTokenError, match=r"^cannot read --web-token-file .*latin1: 'utf-8' codec can't decode"):
        read_web_token(tmp_path / "latin1")
    with pytest.raises(WebTokenError, match=r"two-words: the token must be one word of printable characters$"):
        read_web_token(tmp_path / "two-words")
    with pytest.raises(WebTokenError, match=rf"^\${TOKEN_ENV}: the token must be one word of printable characters$"):
        read_web_token(None, {TOKEN_ENV: "two\twords"})


def test_a_token_file_without_web_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from gcs.cli.main import main

    (tmp_path / "token").write_text("s3cret\n")
    assert main(["gcs", "--sitl", "--web-token-file", str(tmp_path / "token")]) == 2
    assert capsys.readouterr() == ("", "vil gcs: --web-token-file needs --web (the token guards the browser console)\n")


def test_a_request_from_another_origin_is_refused_even_with_the_cookie() -> None:
    """A page of another port on the same host gets the cookie sent along (SameSite is per site):
    its websocket must still be refused. Requests without an Origin (not a browser page's) pass."""
    from gcs.console.web import same_origin

    assert same_origin(None, "127.0.0.1:8000")
    assert same_origin("http://127.0.0.1:8000", "127.0.0.1:8000")
    assert same_origin("http://LOCALHOST:8000", "localhost:8000")
    assert not same_origin("http://127.0.0.1:9999", "127.0.0.1:8000")
    assert not same_origin("https://evil.example", "127.0.0.1:8000")
    assert not same_origin("null", "127.0.0.1:8000")
