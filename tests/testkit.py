"""Small helpers every test folder uses (tests/ is on the import path through its conftest)."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

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
