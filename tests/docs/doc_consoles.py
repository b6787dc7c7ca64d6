"""How the console examples run (`vil gcs`, `vil replay`) and what of their claims is checked (the
registry's "consoles" room). Each console runs as an operator runs it, on a pseudo-terminal: the test
reads what it draws and presses its keys, and it must exit 0."""

from __future__ import annotations

import asyncio
import json
import re
import shutil
import signal
import time
from pathlib import Path

from doc_harness import ESCAPES, Work, ports_held

GCS_SITL = "vil gcs --sitl"
WEB = "vil gcs --sitl --web 8000"
WEB_ALL = "vil gcs --sitl --web 0.0.0.0:8000"
REPLAY = "vil replay runs/latest"
GCS_X2 = "vil gcs --sitl --scenario missions/pool12x2.toml"
GCS_RESUME = "vil gcs --sitl --resume"
CRASH_SPEED = "--speed 100"


def run_gcs_sitl(w: Work) -> None:
    """the console with an embedded SITL aPad: its screen (map, status of the embedded aPad), ? shows
    every key, q quits (exit 0) and says where the logs are."""
    console = w.console(w.line(GCS_SITL))
    try:
        console.wait("Map", "embedded SITL", "aPad 1")
        mark = console.press("?")
        console.wait("Live console.", "Pause/resume", "Dock selected", "Quit now", "esc closes", since=mark)
        console.press("?")  # ? closes it again
        assert console.quit() == 0, console.text()[-2000:]
    finally:
        console.close()
    assert "vil gcs: logs in runs/console-pool12-run1" in console.text()
    assert (w.path / "runs/console-pool12-run1/events.jsonl").stat().st_size > 0


def run_web(w: Work) -> None:
    """the same console served to a browser, offline: the address it prints is http://127.0.0.1:8000/,
    the page loads nothing from another machine, and its terminal shows the console (then Q ends it)."""
    with ports_held(8000, kind="tcp"):
        server = w.start(w.line(WEB))
        try:
            line = server.wait_output(r"^vil gcs: serving the console .*$").group(0)
            assert "open http://127.0.0.1:8000/ " in line, line
            screen = asyncio.run(_browse("http://127.0.0.1:8000/"))
            assert "embedded SITL" in screen and "aPad 1" in screen, screen[-2000:]
        finally:
            status = server.stop(signal.SIGTERM)
    assert status == 0, server.output
    assert (w.path / "runs/console-pool12-run1/events.jsonl").exists()


def run_web_all(w: Work) -> None:
    """for the boat's network: served on every interface; the address printed carries a token, and
    without it the page is refused (403), with it served."""
    with ports_held(8000, kind="tcp", host="0.0.0.0"):
        server = w.start(w.line(WEB_ALL))
        try:
            line = server.wait_output(r"^vil gcs: serving the console .*$").group(0)
            assert "on every network of this machine: open http://<this machine's address>:8000/?token=" in line
            here = re.search(r"\(here: (http://127\.0\.0\.1:8000/\?token=[^\s)]+)\)", line)
            assert here, line
            without, with_token = asyncio.run(_statuses(here.group(1)))
        finally:
            status = server.stop(signal.SIGTERM)
    assert without == 403 and with_token == 200
    assert status == 0, server.output


async def _statuses(url: str) -> tuple[int, int]:
    """The page's HTTP status without its token, and with it."""
    import aiohttp

    async with aiohttp.ClientSession() as session:
        async with session.get(url.split("?", 1)[0]) as refused:
            assert "needs its token" in await refused.text()
            without = refused.status
        async with session.get(url) as page:
            return without, page.status


async def _browse(url: str) -> str:
    """What a browser does: the page, then its terminal's websocket until the console is drawn; Q."""
    import aiohttp

    async with aiohttp.ClientSession() as session:
        async with session.get(url) as page:
            assert page.status == 200
            html = await page.text()
        outside = [u for u in re.findall(r"""(?:src|href)=["']([^"']+)""", html)
                   if re.match(r"^(https?:)?//", u) and not re.match(r"^(https?:)?//127\.0\.0\.1:8000/", u)]
        assert outside == [], outside  # offline: nothing from any other machine
        ws_url = re.search(r'data-session-websocket-url="([^"]+)"', html).group(1)  # type: ignore[union-attr]
        received = bytearray()
        async with session.ws_connect(f"{ws_url}?width=150&height=46") as ws:
            await ws.send_json(["resize", {"width": 150, "height": 46}])
            deadline = time.monotonic() + 60
            screen = ""
            while not ("embedded SITL" in screen and "aPad 1" in screen) and time.monotonic() < deadline:
                message = await ws.receive(timeout=max(0.1, deadline - time.monotonic()))
                if message.type == aiohttp.WSMsgType.BINARY:
                    received.extend(message.data)
                    screen = ESCAPES.sub(b" ", bytes(received)).decode("utf-8", "replace")
                elif message.type in (aiohttp.WSMsgType.CLOSE, aiohttp.WSMsgType.CLOSED, aiohttp.WSMsgType.ERROR):
                    break
            await ws.send_json(["stdin", "Q"])  # quit now: the session ends
            async for _ in ws:  # until the server closes it
                pass
        return screen


def run_replay(w: Work) -> None:
    """the console's screen, driven from the last recorded run (the run's strategy, its events, its
    end); q quits."""
    shutil.copytree(w.fixture("recorded_runs") / "runs", w.path / "runs", symlinks=True)
    strategy = json.loads((w.path / "runs/latest/result.json").read_text())["strategy"]
    run = (w.path / "runs/latest").resolve().name  # the title names the run, not `latest`
    console = w.console(w.line(REPLAY))
    try:
        console.wait("Map", f"REPLAY of {run}", f"strategy {strategy}", "events", "mission_start")
        assert console.quit() == 0, console.text()[-2000:]
    finally:
        console.close()


def run_gcs_x2(w: Work) -> None:
    """two aPads in one console, each in a colour of its own on the map panel; a picks the aPad the keys
    command (the next one, logged as the operator's choice); q quits."""
    console = w.console(w.line(GCS_X2))
    try:
        console.wait("◆ aPad 1", "◆ aPad 2", "share 6")
        mark = console.press("a")
        console.wait("aPad 2: operator select_apad", since=mark)
        assert console.quit() == 0, console.text()[-2000:]
    finally:
        console.close()
    by_apad = _colours(bytes(console.raw))
    assert set(by_apad) == {b"1", b"2"} and by_apad[b"1"] != by_apad[b"2"], by_apad


def _colours(raw: bytes) -> dict[bytes, bytes]:
    """aPad number -> the foreground colour its ◆ label is drawn in."""
    found = re.findall(rb"\x1b\[([0-9;]*)m\xe2\x97\x86 aPad (\d)", raw)
    return {apad: re.search(rb"38;(5;\d+|2;\d+;\d+;\d+)", sgr).group(1)  # type: ignore[union-attr]
            for sgr, apad in found}


def run_gcs_resume(w: Work) -> None:
    """a console mission killed (SIGKILL) while aMussels charge on the aPad, then `--resume`: the same
    folder goes on from the checkpoint, at the pace it had, and the aMussels docked at the crash are
    released before any of them is called up again; q quits."""
    from gcs.mission.checkpoint import load as load_checkpoint
    from gcs.records.run_folder import CHECKPOINT
    from mussel_sim.vocabulary import MusselState

    folder = w.path / "runs" / "console-pool12-run1"
    crashed = w.console(f"{GCS_SITL} {CRASH_SPEED}")
    try:
        crashed.wait_until("checkpoint in a charging wait", lambda: _charging(folder / CHECKPOINT), timeout_s=120)
        crashed.kill()
    finally:
        crashed.close()
    saved = load_checkpoint(folder / CHECKPOINT)
    docked = [int(i) for i, s in zip(saved.fleet_state.ids, saved.fleet_state.state, strict=True)
              if s == MusselState.DOCKED]
    assert docked
    console = w.console(w.line(GCS_RESUME))
    try:
        console.wait("Map", "embedded SITL")
        console.wait_until("release of the docked", lambda: _released(folder / "events.jsonl", docked), timeout_s=90,
                           period_s=0.1)
        assert console.quit() == 0, console.text()[-2000:]
    finally:
        console.close()
    events = [json.loads(x) for x in (folder / "events.jsonl").read_text().splitlines()]
    kinds = [e["event"] for e in events]
    assert kinds.count("mission_start") == kinds.count("mission_resume") == 1
    resume = kinds.index("mission_resume")
    assert saved.time_us / 1e6 <= events[resume]["t_s"] < saved.time_us / 1e6 + 10
    for mussel in docked:
        mine = [e["event"] for e in events[resume:] if e.get("mussel") == mussel and e["event"] in
                ("call_up", "released", "docked")]
        assert mine[:1] == ["released"], (mussel, mine)
    assert sorted(p.name for p in (w.path / "runs").iterdir()) == ["console-pool12-run1", "latest"]


def _charging(path: Path) -> bool:
    from gcs.loop.control import Phase
    from gcs.mission.checkpoint import load as load_checkpoint

    if not path.exists():
        return False
    try:
        saved = load_checkpoint(path)
    except Exception:  # caught mid-write: look again
        return False
    return bool(saved.loop_statuses[1].phase == Phase.CHARGING_WAIT)


def _released(events: Path, mussels: list[int]) -> bool:
    lines = [json.loads(x) for x in events.read_text().splitlines() if x.strip()]
    after = lines[[e["event"] for e in lines].index("mission_resume") + 1:] if any(
        e["event"] == "mission_resume" for e in lines) else []
    return {e.get("mussel") for e in after if e["event"] == "released"} >= set(mussels)


MODEM_SEA = "vil modem --scenario pool12-acoustic --sea udp:127.0.0.1:14660"
GCS_MODEM = "vil gcs --sitl --scenario missions/pool12-acoustic.toml --modem /dev/pts/3 --sea udp:127.0.0.1:14660"


def run_gcs_modem(w: Work) -> None:
    """vil modem prints its pty first and names its sea; the console given that pty hears the aMussels
    through it (the fleet table's ages) and calls one up (an acknowledged call-up in its events); Q ends
    it (exit 0), and vil modem ends on SIGTERM (exit 0) having heard the reports."""
    with ports_held(14660, kind="udp"):
        modem = w.start(w.line(MODEM_SEA))
        try:
            device = modem.wait_output(r"^(/dev/\S+)$", timeout_s=60.0).group(1)
            assert "their sea at udp:127.0.0.1:14660" in modem.wait_output(r"^vil modem: nanomodem v3.*$").group(0)
            console = w.console(w.line(GCS_MODEM).replace("/dev/pts/3", device))
            events = w.path / "runs/console-pool12-acoustic-run1/events.jsonl"
            try:
                console.wait("heard", "embedded SITL")
                console.wait_until("an acknowledged call-up", lambda: events.exists() and any(
                    json.loads(line).get("acked") is True for line in events.read_text().splitlines()
                    if '"call_up"' in line), timeout_s=120.0)
                console.press("Q")
                console.wait_until("the console's end", lambda: console.popen.poll() is not None, timeout_s=30.0)
                assert console.popen.returncode == 0, console.text()[-2000:]
            finally:
                console.close()
        finally:
            status = modem.stop()
    assert status == 0 and "vil modem: stopped;" in modem.output and "heard" in modem.output, modem.output
