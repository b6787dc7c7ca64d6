"""Small helpers every test folder uses (tests/ is on the import path through its conftest)."""

from __future__ import annotations

import contextlib
import fcntl
import json
import math
import os
import pty
import re
import select
import shlex
import signal
import socket
import struct
import subprocess
import sys
import termios
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from mavlink_dialect import Codec, mavlink
from mussel_sim.geo import LocalFrame

MISSIONS = Path(__file__).resolve().parents[1] / "missions"


def free_udp_port() -> int:
    """A UDP port nobody on 127.0.0.1 is bound to right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def read_jsonl(path: Path) -> list[dict[str, Any]]:
    """Every line of an event log."""
    return [json.loads(line) for line in path.read_text().splitlines()]


def scenario_variant(name: str, out: Path, replace: dict[str, str]) -> Path:
    """missions/NAME.toml written to `out` with each `replace` key swapped for its value, its area
    and start files still found (paths made absolute)."""
    text = (MISSIONS / f"{name}.toml").read_text()
    text = text.replace('"areas/', f'"{MISSIONS}/areas/').replace('"starts/', f'"{MISSIONS}/starts/')
    for old, new in replace.items():
        assert old in text, f"{old!r} not in {name}.toml"
        text = text.replace(old, new)
    out.write_text(text)
    return out


VIL_MODEM_START_S = 60.0  # `vil modem`'s first line (its imports on a loaded machine); past it a test fails


def start_vil_modem(*args: str) -> tuple[str, subprocess.Popen[str]]:
    """`vil modem ARGS` as a real process, and the serial device its first line names."""
    proc = subprocess.Popen([str(Path(sys.executable).parent / "vil"), "modem", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    ready, _, _ = select.select([proc.stdout], [], [], VIL_MODEM_START_S)
    assert ready, "vil modem printed no device within the bound"
    device = proc.stdout.readline().strip()
    assert device.startswith("/dev/"), device
    return device, proc


@contextmanager
def sigint_as_in_a_terminal() -> Iterator[None]:
    """Processes started inside see Ctrl-C as a terminal's foreground job does: a suite started in the
    background (`make test &`) has SIGINT ignored, every process it starts inherits that, and Python keeps
    an inherited SIG_IGN. A handled SIGINT is reset to the default by exec, so the child's Python installs
    its KeyboardInterrupt again."""
    before = signal.getsignal(signal.SIGINT)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, before)


def ctrl_c_after_checkpoint(argv: list[str], cwd: Path, env: dict[str, str], checkpoint: Path, past_s: float,
                            timeout_s: float) -> tuple[int, str]:
    """Start `argv` as a terminal's job would, Ctrl-C it once its checkpoint is past `past_s` of mission
    time, and return its exit status and stderr (it must still be running until then)."""
    from gcs.mission.checkpoint import CheckpointError, load

    with sigint_as_in_a_terminal():
        proc = subprocess.Popen(argv, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        deadline = time.monotonic() + timeout_s
        while True:
            assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
            try:
                if checkpoint.exists() and load(checkpoint).time_us > past_s * 1e6:
                    break
            except CheckpointError:  # caught mid-write
                pass
            time.sleep(0.05)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=timeout_s)
    finally:
        if proc.poll() is None:
            proc.kill()
    return proc.returncode, err


DASK = Path(sys.executable).parent / "dask"
DASK_START_TIMEOUT_S = 60.0


def free_tcp_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@contextmanager
def dask_processes(folder: Path, workers: int = 2) -> Iterator[str]:
    """`dask scheduler` and `workers` x `dask worker` as processes of their own; killed on the way out."""
    from distributed import Client  # here: most tests that use this kit need no Dask

    address = f"tcp://127.0.0.1:{free_tcp_port()}"
    port = address.rsplit(":", 1)[1]
    log = (folder / "dask.log").open("w")
    procs: list[subprocess.Popen[bytes]] = []
    try:
        procs.append(subprocess.Popen([DASK, "scheduler", "--host", "127.0.0.1", "--port", port,
                                       "--dashboard-address", ":0"], stdout=log, stderr=subprocess.STDOUT,
                                      cwd=folder))
        for i in range(workers):
            procs.append(subprocess.Popen([DASK, "worker", address, "--nthreads", "1", "--no-nanny",
                                           "--no-dashboard", "--local-directory", str(folder / f"worker{i}")],
                                          stdout=log, stderr=subprocess.STDOUT, cwd=folder))
        with Client(address, timeout=DASK_START_TIMEOUT_S) as client:
            client.wait_for_workers(workers, timeout=DASK_START_TIMEOUT_S)
        yield address
    finally:
        for proc in procs:  # nothing of theirs to keep: a graceful close only waits on reconnects
            proc.kill()
        for proc in procs:
            proc.wait()
        log.close()


# --- a console on a pseudo-terminal, as an operator runs it ---------------------------------------

ESCAPES = re.compile(rb"\x1b\[[0-9;?<>=]*[ -/]*[@-~]|\x1b\][^\x07\x1b]*(?:\x07|\x1b\\)|\x1b[()][0-9A-Za-z]|\x1b[=>78]")


def words(text: str) -> str:
    """`text` with every run of blanks one space: rich wraps its lines at the terminal's width."""
    return " ".join(text.split())


class PtyConsole:
    """A process (a `vil gcs` console) whose terminal is a pseudo-terminal of `rows` x `columns`:
    Textual's real driver draws into it, a thread collects what is drawn, keys are typed into it.

    `stdout`: a file for the process's stdout (what it prints after the console closes) instead of
    the terminal. `keep_bytes`: keep only the last that many bytes drawn (a long mission's drawing,
    kept for a failure message); then `mark` and `text(since)` count within what is kept."""

    def __init__(self, argv: list[str], cwd: Path, env: dict[str, str], rows: int = 46, columns: int = 150,
                 stdout: Path | None = None, keep_bytes: int | None = None) -> None:
        self.line = shlex.join(argv)
        self.stdout = stdout
        master, slave = pty.openpty()
        fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", rows, columns, 0, 0))
        with contextlib.ExitStack() as files:
            out = files.enter_context(stdout.open("wb")) if stdout is not None else slave
            self.popen = subprocess.Popen(argv, cwd=cwd, env={**env, "TERM": "xterm-256color"}, stdin=slave,
                                          stdout=out, stderr=slave, start_new_session=True)
        os.close(slave)
        self.master = master
        self.raw = bytearray()
        self._keep = keep_bytes
        self._lock = threading.Lock()
        threading.Thread(target=self._drain, daemon=True).start()

    def _drain(self) -> None:
        while True:
            try:
                data = os.read(self.master, 1 << 16)
            except OSError:  # the process is gone
                return
            if not data:
                return
            with self._lock:
                self.raw.extend(data)
                if self._keep is not None and len(self.raw) > self._keep:
                    del self.raw[: len(self.raw) - self._keep]

    def mark(self) -> int:
        with self._lock:
            return len(self.raw)

    def text(self, since: int = 0) -> str:
        """What was drawn from byte `since` on, escape sequences taken out (the words of the screen)."""
        with self._lock:
            data = bytes(self.raw[since:])
        return ESCAPES.sub(b" ", data).decode("utf-8", "replace")

    def alive(self) -> None:
        assert self.popen.poll() is None, f"{self.line!r} exited {self.popen.returncode}: {self.text()[-2000:]!r}"

    def wait_until(self, what: str, condition: Callable[[], object], timeout_s: float = 60.0,
                   period_s: float = 0.05) -> None:
        """Poll `condition` until it holds, the console still running; fails at `timeout_s` naming `what`."""
        deadline = time.monotonic() + timeout_s
        while not condition():
            self.alive()
            assert time.monotonic() < deadline, f"{self.line!r}: no {what} in {timeout_s:g} s: {self.text()[-2000:]!r}"
            time.sleep(period_s)

    def wait(self, *phrases: str, since: int = 0, timeout_s: float = 60.0) -> str:
        """Wait until every phrase is on screen (blanks compared as one space); the words drawn."""
        drawn = ""

        def on_screen() -> bool:
            nonlocal drawn
            drawn = words(self.text(since))
            return all(words(p) in drawn for p in phrases)

        self.wait_until(f"{list(phrases)} on screen", on_screen, timeout_s)
        return drawn

    def press(self, keys: str | bytes) -> int:
        """Type `keys`; the mark of what is drawn after them."""
        mark = self.mark()
        os.write(self.master, keys.encode() if isinstance(keys, str) else keys)
        return mark

    def quit(self, timeout_s: float = 20.0) -> int:
        """q, and y if the console asks first (aMussels at the surface); the exit status."""
        mark = self.press("q")
        deadline = time.monotonic() + timeout_s
        asked = False
        while self.popen.poll() is None:
            if not asked and "Quit?" in self.text(mark):
                self.press("y")
                asked = True
            assert time.monotonic() < deadline, f"{self.line!r} did not quit: {self.text(mark)[-2000:]!r}"
            time.sleep(0.05)
        return int(self.popen.returncode)

    def kill(self) -> None:
        """SIGKILL to its process group (a crash), and reap it."""
        if self.popen.poll() is None:
            os.killpg(self.popen.pid, signal.SIGKILL)
        self.popen.wait(10)

    def close(self) -> None:
        self.kill()
        with contextlib.suppress(OSError):
            os.close(self.master)


def restored_session(scenario: Any, folder: Path, saved: Any = None) -> Any:
    """The console's way back, in process: the checkpoint in `folder` (or `saved`, one read from it and
    altered), the logs cut back to it, a fresh lockstep world whose clock starts at its time, and the
    session that restores it (not started). The caller closes the session and then its world."""
    from gcs.mission import checkpoint
    from gcs.mission.session import MissionSession
    from gcs.mission.world import LinkOptions, build_world
    from gcs.records.run_folder import RunFolder
    from missiontime import VirtualClock

    files = checkpoint.CheckpointFiles(RunFolder(folder).checkpoint)
    saved = files.read() if saved is None else saved
    checkpoint.cut_logs(RunFolder(folder), saved)
    world = build_world(scenario, VirtualClock(start_us=saved.time_us), folder, LinkOptions(), mission_start_us=0,
                        append_logs=True)
    return MissionSession(world, files, saved, setup=checkpoint.setup_digest(scenario))


def go_to_bytes(gcs: Codec, frame: LocalFrame, x_m: float, y_m: float) -> bytes:
    """A Go To (DO_REPOSITION as COMMAND_INT, mode changed) to (`x_m`, `y_m`) of `frame`, as `gcs` encodes it."""
    lat, lon = frame.to_geodetic(x_m, y_m)
    return gcs.encode(mavlink.MAVLink_command_int_message(
        1, 1, mavlink.MAV_FRAME_GLOBAL_INT, mavlink.MAV_CMD_DO_REPOSITION, 0, 0, -1.0,
        mavlink.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, 0.0, math.nan, round(float(lat) * 1e7), round(float(lon) * 1e7),
        0.0))


def command_bytes(gcs: Codec, command: int, *params: float) -> bytes:
    """A COMMAND_LONG to system 1 with `params` (the rest 0), as `gcs` encodes it."""
    p = list(params) + [0.0] * (7 - len(params))
    return gcs.encode(mavlink.MAVLink_command_long_message(1, 1, command, 0, *p))

