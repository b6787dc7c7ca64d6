"""Real processes for the interop tests: `vil sitl`, MAVProxy and pymavlink's tools, on free UDP ports.

Every process started through `Procs` (the `procs` fixture) is stopped at teardown (SIGTERM, then SIGKILL), its pipes
closed and its output kept, so a failing test shows what the third-party tool printed.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

BIN = Path(sys.executable).parent  # the venv's bin/: `vil`, `mavproxy.py`, `mavlogdump.py`
HOME = (43.9400, 15.4400)  # `vil sitl`'s default home, passed explicitly
STOP_TIMEOUT_S = 5.0



def wait_until(predicate: Callable[[], Any], timeout_s: float, what: str, poll_s: float = 0.05) -> Any:
    """Poll `predicate` until it returns something truthy; fail the test after `timeout_s`."""
    deadline = time.monotonic() + timeout_s
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() >= deadline:
            pytest.fail(f"timed out after {timeout_s:g} s waiting for {what}")
        time.sleep(poll_s)


def tool(name: str) -> Path:
    """A console script installed in this venv (`mavproxy.py`, `mavlogdump.py`, `vil`)."""
    path = BIN / name
    if not path.is_file():
        missing = f"{name} is not installed beside {sys.executable} (pip install -e '.[interop]')"
        if os.environ.get("CI"):
            pytest.fail(missing)  # CI installs the interop extras: a missing tool is a broken setup
        pytest.skip(missing)
    return path


class Proc:
    """A subprocess whose stdout+stderr is collected line by line on a reader thread."""

    def __init__(self, name: str, argv: list[str], cwd: Path, env: dict[str, str], stdin: bool) -> None:
        self.name = name
        self.argv = argv
        self.popen = subprocess.Popen(
            argv, cwd=cwd, env=env, text=True, bufsize=1,
            stdin=subprocess.PIPE if stdin else subprocess.DEVNULL,
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
        )
        self._lines: list[str] = []
        self._lock = threading.Lock()
        self._reader = threading.Thread(target=self._read, name=f"{name}-stdout", daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.popen.stdout is not None
        for line in self.popen.stdout:
            with self._lock:
                self._lines.append(line.rstrip("\n"))

    @property
    def output(self) -> str:
        with self._lock:
            return "\n".join(self._lines)

    def wait_output(self, pattern: str, timeout_s: float, start: int = 0) -> re.Match[str]:
        """Wait until `pattern` (a regex, ^ and $ per line) matches the output from character `start` on."""
        regex = re.compile(pattern, re.MULTILINE)

        def found() -> re.Match[str] | None:
            match = regex.search(self.output, start)
            if match is None and self.popen.poll() is not None:
                pytest.fail(f"{self.name} exited ({self.popen.returncode}) before printing /{pattern}/:\n{self.output}")
            return match

        deadline = time.monotonic() + timeout_s
        while (match := found()) is None:
            if time.monotonic() >= deadline:
                pytest.fail(f"{self.name} did not print /{pattern}/ within {timeout_s:g} s; it printed:\n{self.output}")
            time.sleep(0.05)
        return match

    def send(self, line: str) -> int:
        """Write one command line to stdin; returns the output length before it, for `wait_output(start=)`."""
        mark = len(self.output)
        assert self.popen.stdin is not None
        self.popen.stdin.write(line + "\n")
        self.popen.stdin.flush()
        return mark

    def stop(self) -> int:
        """End the process (EOF on stdin, then SIGTERM, then SIGKILL); return its exit code."""
        p = self.popen
        if p.stdin is not None and not p.stdin.closed:
            with contextlib.suppress(BrokenPipeError):
                p.stdin.close()  # MAVProxy's console stops on EOF and unloads its modules
            with contextlib.suppress(subprocess.TimeoutExpired):
                p.wait(timeout=STOP_TIMEOUT_S)
        if p.poll() is None:
            p.send_signal(signal.SIGTERM)
            try:
                p.wait(timeout=STOP_TIMEOUT_S)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        self._reader.join(timeout=STOP_TIMEOUT_S)
        if p.stdout is not None:
            p.stdout.close()
        return int(p.returncode)


class Procs:
    """Starts the processes of one test; `close()` stops whatever is still running."""

    def __init__(self, workdir: Path) -> None:
        self.workdir = workdir
        self.started: list[Proc] = []
        # Hermetic: no ~/.mavinit.scr or ~/.mavproxy of the developer's, no colour codes, unbuffered.
        self.env = {**os.environ, "HOME": str(workdir), "PYTHONUNBUFFERED": "1", "NO_COLOR": "1"}

    def start(self, name: str, argv: list[str], stdin: bool = False) -> Proc:
        proc = Proc(name, argv, self.workdir, self.env, stdin)
        self.started.append(proc)
        return proc

    def sitl(self, *args: str, log_dir: Path | None = None) -> Proc:
        """`vil sitl ARGS` at HOME; returns once it has opened its transport."""
        argv = [str(tool("vil")), "sitl", "--home", f"{HOME[0]},{HOME[1]}", *args]
        if log_dir is not None:
            argv += ["--log-dir", str(log_dir)]
        proc = self.start("vil sitl", argv)
        proc.wait_output(r"vil sitl: aPad sysid \d+ (listening on|connecting to)", timeout_s=10.0)
        return proc

    def with_dialect(self, name: str, script: str, *args: str, stdin: bool = False) -> Proc:
        """A pymavlink/MAVProxy console script run through our dialect launcher."""
        argv = [sys.executable, "-m", "mavlink_dialect.run_with_dialect", str(tool(script)), *args]
        return self.start(name, argv, stdin=stdin)

    def run_with_dialect(self, script: str, *args: str, timeout_s: float = 30.0) -> subprocess.CompletedProcess[str]:
        """Run a one-shot tool (e.g. `mavlogdump.py`) through our dialect launcher to the end."""
        argv = [sys.executable, "-m", "mavlink_dialect.run_with_dialect", str(tool(script)), *args]
        done = subprocess.run(argv, cwd=self.workdir, env=self.env, capture_output=True, text=True,
                              timeout=timeout_s, check=False)
        assert done.returncode == 0, f"{script} failed ({done.returncode}):\n{done.stdout}\n{done.stderr}"
        return done

    def close(self) -> None:
        for proc in reversed(self.started):
            proc.stop()


def read_events(log_dir: Path) -> list[dict[str, Any]]:
    """The SITL's JSON-lines event log (the aPad's own record of what it did and why)."""
    (path,) = log_dir.glob("*.events.jsonl")
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines() if line.strip()]
