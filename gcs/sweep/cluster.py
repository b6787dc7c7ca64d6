"""Running a sweep's cells on Dask: a local cluster (a process per core, one thread each) or an
existing one at a scheduler's address. Each finished cell is handed back to the client, which
writes it (so a cluster on other machines needs no shared folder, unless runs are kept)."""

from __future__ import annotations

import hashlib
import logging
import os
import signal
import tempfile
import threading
import traceback
from collections.abc import Callable, Iterator
from contextlib import contextmanager, suppress
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from distributed import Client, LocalCluster, as_completed
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

from gcs.sweep.cells import Cell, run_cell

# What a worker does with a cell: (cell, runs_dir) -> {"result": result.json's dict, "series": the active count}.
CellRunner = Callable[[Cell, str | None], dict[str, Any]]

CONNECT_TIMEOUT_S = 20.0
QUIET_BOUND_S = 2.0  # how long a Ctrl-C's closing waits for the workers to mute their heartbeat log


class ClusterError(RuntimeError):
    """The cluster could not be started or reached (one line)."""


@dataclass(frozen=True)
class Failure:
    cell: Cell
    why: str  # one line: the exception
    trace: str  # where it was raised, on the worker


@dataclass
class Outcome:
    ran: int = 0
    failed: list[Failure] = field(default_factory=list)


@contextmanager
def dask_client(scheduler: str | None, workers: int | None = None, processes: bool = True) -> Iterator[Client]:
    """A client of the scheduler at `scheduler` (tcp://HOST:PORT), or of a local cluster of
    `workers` (default: cores) single-threaded workers, closed on the way out."""
    if scheduler is not None:
        try:
            client = Client(scheduler, timeout=CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError, ValueError) as exc:
            raise ClusterError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from None
        with client:
            yield client
        return
    n = workers or os.cpu_count() or 1
    # The scheduler's HTTP server on a free port: the default 8787 may be another cluster's. The
    # worker processes start with Ctrl-C ignored (they inherit it): a Ctrl-C in the terminal reaches
    # the whole process group, and only this process should answer it, by closing the cluster in order.
    with _ctrl_c_ignored():
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=processes, dashboard_address=":0",
                               silence_logs=logging.ERROR)
    with cluster, Client(cluster) as client:
        try:
            yield client
        except KeyboardInterrupt:
            _quiet_heartbeats(client)
            raise


def _quiet_heartbeats(client: Client) -> None:
    """Before a Ctrl-C closes the local cluster: a worker whose heartbeat is in flight as the scheduler
    closes logs it as an error with a traceback (distributed.worker, "Failed to communicate with
    scheduler during heartbeat"), which is no error of the sweep's; only a Ctrl-C's closing mutes it."""
    def mute() -> None:
        with suppress(Exception):  # a worker already gone: nothing of its to mute
            client.run(_mute_worker_log, on_error="return")

    muting = threading.Thread(target=mute, name="vil-sweep-mute", daemon=True)
    muting.start()
    muting.join(QUIET_BOUND_S)  # a worker that does not answer: close the cluster all the same


def _mute_worker_log() -> None:
    logging.getLogger("distributed.worker").setLevel(logging.CRITICAL)


@contextmanager
def _ctrl_c_ignored() -> Iterator[None]:
    """SIGINT ignored meanwhile (in the main thread; elsewhere signals cannot be set: nothing done)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def ship_strategies(client: Client, cells: list[Cell]) -> list[Cell]:
    """Strategies from files, sent to every worker as Dask sends user code (`Client.upload_file`: into
    each worker's folder, on its sys.path, imported there). Each goes under a name of its own,
    `vil_strategy_<stem>_<digest>`, so a file called random.py or test.py cannot meet a module of that
    name on the worker; the cells then name each by that module, so a worker never needs the file
    at the client's path."""
    files = {c.strategy_source for c in cells if c.strategy_source.partition(":")[0].endswith(".py")
             and ".py:" in c.strategy_source}
    modules: dict[str, str] = {}
    with tempfile.TemporaryDirectory(prefix="vil-ship-") as tmp:
        for source in sorted(files):
            path, _, function = source.rpartition(":")
            text = Path(path).read_bytes()
            module = f"vil_strategy_{Path(path).stem}_{hashlib.sha256(text).hexdigest()[:10]}"
            copy = Path(tmp) / f"{module}.py"
            copy.write_bytes(text)
            try:
                client.upload_file(str(copy))
            except Exception as exc:  # a worker that cannot import it says why
                raise ClusterError(f"sending {path} to the workers failed: {type(exc).__name__}: "
                                   f"{str(exc).splitlines()[0] if str(exc) else ''}") from None
            modules[source] = f"{module}:{function}"
    return [replace(c, strategy_source=modules[c.strategy_source]) if c.strategy_source in modules else c
            for c in cells]


def describe(client: Client) -> str:
    info = client.scheduler_info(n_workers=-1)
    threads = sum(w.get("nthreads", 0) for w in info["workers"].values())
    return f"{info['address']} ({len(info['workers'])} workers, {threads} threads)"


def run_cells(
    client: Client, cells: list[Cell], runs_dir: str | None, on_done: Callable[[Cell, dict[str, Any]], None],
    console: Console, runner: CellRunner = run_cell,
) -> Outcome:
    """Every cell on the cluster; `on_done` gets each result as it comes, in any order. A cell whose
    mission raised is listed in the outcome, not written, so the next run tries it again. `runner`: what a
    worker does with a cell (a mission; a test function of known answer, to check the path around it)."""
    outcome = Outcome()
    columns = (TextColumn("[progress.description]{task.description}"), BarColumn(), MofNCompleteColumn(),
               TextColumn("missions"), TimeElapsedColumn(), TextColumn("eta"), TimeRemainingColumn())
    with Progress(*columns, console=console, transient=False) as progress:
        task = progress.add_task("sweep", total=len(cells))
        futures = {
            client.submit(runner, cell, runs_dir, key=f"vil-sweep-{cell.key}", retries=0,
                          priority=_work(cell)): cell
            for cell in cells
        }
        for future in as_completed(futures):
            cell = futures.pop(future)
            if future.status == "error":
                exc = future.exception()
                trace = "".join(traceback.format_exception(type(exc), exc, future.traceback()))
                outcome.failed.append(Failure(cell, f"{type(exc).__name__}: {exc}", trace))
            else:
                on_done(cell, future.result())
                outcome.ran += 1
            future.release()
            progress.advance(task)
    return outcome


def _work(cell: Cell) -> int:
    """A mission's rough cost, aMussel-seconds: the longest start first, so no worker is left with a
    long one at the end while the others idle."""
    s = cell.scenario
    return int(s.fleet.count * s.mission.duration_s)
