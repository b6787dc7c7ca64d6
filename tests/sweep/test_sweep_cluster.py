"""The same sweep on a local cluster and on a separately started `dask scheduler` with two `dask
worker` processes gives the same rows (but the wall times)."""

from __future__ import annotations

import io
import socket
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pandas as pd
import pytest
from distributed import Client
from rich.console import Console

from gcs.sweep.cells import make_cells
from gcs.sweep.runner import sweep
from gcs.sweep.spec import load_spec

DASK = Path(sys.executable).parent / "dask"
START_TIMEOUT_S = 60.0

SPEC = """
[sweep]
scenarios = ["pool12"]
strategies = {strategies}
seeds = "{seeds}"
[set]
mission.duration = "{duration}"
mission.theta = 60
"""


def free_tcp_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@contextmanager
def dask_processes(folder: Path, workers: int = 2) -> Iterator[str]:
    """`dask scheduler` and `workers` x `dask worker` as processes of their own; killed on the way out."""
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
        with Client(address, timeout=START_TIMEOUT_S) as client:
            client.wait_for_workers(workers, timeout=START_TIMEOUT_S)
        yield address
    finally:
        for proc in procs:  # nothing of theirs to keep: a graceful close only waits on reconnects
            proc.kill()
        for proc in procs:
            proc.wait()
        log.close()


def figures(out: Path) -> pd.DataFrame:
    rows = pd.read_parquet(out / "results.parquet")
    return rows.drop(columns=[c for c in rows.columns if c.endswith("wall_s")])


def same_rows_on_both(tmp_path: Path, text: str, local_processes: bool) -> pd.DataFrame:
    (tmp_path / "spec.toml").write_text(text)
    spec = load_spec(tmp_path / "spec.toml")
    cells = make_cells(spec)
    console = Console(file=io.StringIO())
    local = sweep(spec, cells, tmp_path / "local", console, workers=2 if local_processes else 1,
                  processes=local_processes)
    with dask_processes(tmp_path) as address:
        remote = sweep(spec, cells, tmp_path / "remote", console, scheduler=address)
    assert local.ran == remote.ran == len(cells) and not local.failed and not remote.failed
    rows = figures(tmp_path / "local")
    pd.testing.assert_frame_equal(rows, figures(tmp_path / "remote"))
    assert list(rows["cell"]) == [c.key for c in cells]
    return rows


def test_a_separate_scheduler_and_two_workers_give_the_local_rows(tmp_path: Path) -> None:
    """CI variant: two short missions, the local cluster in this process."""
    rows = same_rows_on_both(tmp_path, SPEC.format(strategies='["cautious", "none"]', seeds="1-1", duration="2m"),
                             local_processes=False)
    assert len(rows) == 2


@pytest.mark.slow
def test_a_separate_scheduler_and_two_workers_give_the_local_rows_of_real_missions(tmp_path: Path) -> None:
    """Six missions long enough to collect, the local cluster as `vil sweep` starts it (processes)."""
    rows = same_rows_on_both(tmp_path, SPEC.format(strategies='["cautious", "greedy"]', seeds="1-3", duration="6m"),
                             local_processes=True)
    assert len(rows) == 6 and (rows["cost_m"] > 0).any()
