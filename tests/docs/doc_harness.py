"""Where and how the doc examples run: a working folder laid out like the repository's root, the shell
that runs an example's line, background processes, a console on a pseudo-terminal, fixed ports.

A `Work` folder holds `missions`, `bench`, `docs`, `Makefile`, `pyproject.toml`, `requirements.lock` (links
to the repository's) and `.venv` (a link to this interpreter's venv), so a line written to run from the
repository's root runs there as written, and whatever it writes stays in the test's tmp_path.
`vil` and `python` are two scripts in `bin/`, first on PATH: `"$PYTHON" -m gcs.cli "$@"` and
`"$PYTHON" "$@"`, with PYTHONPATH the repository.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import re
import shlex
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, Literal

import pytest
from testkit import ESCAPES as ESCAPES  # the doc rooms read these two from here
from testkit import PtyConsole
from testkit import words as words

ROOT = Path(__file__).resolve().parents[2]
VENV = Path(sys.prefix)
LINKED = ("missions", "bench", "docs", "Makefile", "pyproject.toml", "requirements.lock")
PORT_WAIT_S = 300.0  # another test (or another engineer's run) may hold a doc port that long


class Work:
    """One example's working folder and the means to run its lines there.

    `line(command)` is what runs for a registry command: the command itself in a full run, else its
    declared CI variant; `full` says which."""

    def __init__(self, path: Path, full: bool, lines: Callable[[str, bool], str],
                 fixture: Callable[[str], Any]) -> None:
        self.path = path
        self.full = full
        self._lines = lines
        self._fixture = fixture
        for name in LINKED:
            (path / name).symlink_to(ROOT / name)
        (path / ".venv").symlink_to(VENV)
        bin_dir = path / "bin"
        bin_dir.mkdir()
        for name, run in (("vil", '"$PYTHON" -m gcs.cli'), ("python", '"$PYTHON"')):
            script = bin_dir / name
            script.write_text(f'#!/bin/sh\nexec {run} "$@"\n')
            script.chmod(0o755)
        self.env = {**os.environ, "PYTHON": sys.executable, "PYTHONPATH": str(ROOT), "COLUMNS": "160",
                    "PATH": os.pathsep.join([str(bin_dir), str(Path(sys.executable).parent), os.environ["PATH"]]),
                    "PYTHONUNBUFFERED": "1"}
        for name in ("VIL_SIGNING_KEY", "VIL_WEB_TOKEN", "NO_COLOR", "MAKEFLAGS", "MFLAGS", "MAKELEVEL"):
            self.env.pop(name, None)  # as from a terminal: no key of ours, not inside `make test`'s make

    def line(self, command: str) -> str:
        return self._lines(command, self.full)

    def fixture(self, name: str) -> Any:
        """A pytest fixture of tests/docs/conftest.py, made when an example needs it."""
        return self._fixture(name)

    def sh(self, line: str, timeout_s: float = 300.0, expect: int | None = 0,
           cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
        """Run a shell line here (or in `cwd`) to its end; check its exit status unless `expect` is None."""
        done = subprocess.run(["bash", "-c", line], cwd=cwd or self.path, env=self.env,
                              capture_output=True, text=True, timeout=timeout_s, stdin=subprocess.DEVNULL)
        if expect is not None:
            assert done.returncode == expect, (f"{line}\nexit {done.returncode}, not {expect}\n"
                                               f"stdout:\n{done.stdout[-3000:]}\nstderr:\n{done.stderr[-3000:]}")
        return done

    def start(self, line: str) -> Background:
        return Background(self, line)

    def console(self, line: str, rows: int = 46, columns: int = 150) -> PtyConsole:
        """A console example on a pseudo-terminal, as an operator runs it: read what it draws, press keys."""
        return PtyConsole(shlex.split(line), self.path, self.env, rows, columns)


class Background:
    """A long-lived example (a SITL aPad, a Dask scheduler) started here; its output collected."""

    def __init__(self, work: Work, line: str) -> None:
        self.line = line
        self.popen = subprocess.Popen(shlex.split(line), cwd=work.path, env=work.env, text=True,
                                      stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                      start_new_session=True)
        self._lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.popen.stdout is not None
        for text in self.popen.stdout:
            self._lines.append(text.rstrip("\n"))

    @property
    def output(self) -> str:
        return "\n".join(self._lines)

    def wait_output(self, pattern: str, timeout_s: float = 30.0) -> re.Match[str]:
        regex = re.compile(pattern, re.MULTILINE)
        deadline = time.monotonic() + timeout_s
        while (found := regex.search(self.output)) is None:
            assert self.popen.poll() is None, f"{self.line!r} exited {self.popen.returncode}:\n{self.output}"
            assert time.monotonic() < deadline, f"{self.line!r} printed no /{pattern}/ in {timeout_s:g} s:\n" \
                                                f"{self.output}"
            time.sleep(0.05)
        return found

    def stop(self, sig: int = signal.SIGTERM, timeout_s: float = 15.0) -> int:
        """SIGTERM (or `sig`) to its process group; SIGKILL if it does not end. Not Ctrl-C's SIGINT: a
        suite started in the background (`make test &`) hands its processes SIGINT ignored."""
        if self.popen.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.popen.pid, sig)
            try:
                self.popen.wait(timeout_s)
            except subprocess.TimeoutExpired:
                os.killpg(self.popen.pid, signal.SIGKILL)
                self.popen.wait(10)
        self._reader.join(5)
        if self.popen.stdout is not None:
            self.popen.stdout.close()
        return int(self.popen.returncode)


@contextlib.contextmanager
def ports_held(*ports: int, kind: Literal["udp", "tcp"] = "udp", host: str = "127.0.0.1") -> Iterator[None]:
    """Hold the fixed ports an example names (14550, 8000, 8786) for this test: another test on this
    machine, in this run or another's, that needs one waits; a port some other program holds fails."""
    locks = []
    try:
        for port in sorted(ports):
            handle = (Path(tempfile.gettempdir()) / f"vil-doc-examples-{kind}-{port}.lock").open("w")
            locks.append(handle)
            deadline = time.monotonic() + PORT_WAIT_S
            while True:
                try:
                    fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
                    break
                except BlockingIOError:
                    assert time.monotonic() < deadline, f"{kind} port {port}: still held by another doc test"
                    time.sleep(0.2)
            _wait_free(port, kind, host)
        yield
    finally:
        for handle in locks:
            handle.close()  # closing releases the lock


def _wait_free(port: int, kind: str, host: str, timeout_s: float = 10.0) -> None:
    deadline = time.monotonic() + timeout_s
    while True:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM if kind == "udp" else socket.SOCK_STREAM) as probe:
            if kind == "tcp":
                probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as servers bind
            try:
                probe.bind((host, port))
                return
            except OSError as exc:
                if time.monotonic() > deadline:
                    pytest.fail(f"{kind} port {port} on {host} is taken by a program that is not a doc test: {exc}")
        time.sleep(0.2)


@contextlib.contextmanager
def shared_folder(tmp_path_factory: pytest.TempPathFactory, name: str) -> Iterator[tuple[Path, bool]]:
    """A folder every xdist worker of this run shares, and whether it still has to be made (then the
    caller makes it while the others wait on the lock)."""
    worker = os.environ.get("PYTEST_XDIST_WORKER")
    base = tmp_path_factory.getbasetemp()
    root = base.parent if worker else base
    folder = root / name
    with (root / f"{name}.lock").open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        done = folder / ".made"
        if done.exists():
            yield folder, False
            return
        folder.mkdir(exist_ok=True)
        yield folder, True
        done.touch()
