"""A whole sweep: the cells not yet in DIR run on Dask, each written as it finishes, then the tables."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

from rich.console import Console

from gcs.sweep import store
from gcs.sweep.cells import Cell, run_cell
from gcs.sweep.cluster import CellRunner, Failure, dask_client, describe, run_cells, ship_strategies
from gcs.sweep.spec import SweepSpec

FAILED = "failed.txt"  # the tracebacks of the missions that failed in the last run


@dataclass
class SweepOutcome:
    cells: int  # missions in the spec
    skipped: int  # already in DIR: not run again
    ran: int = 0
    failed: list[Failure] = field(default_factory=list)  # not written: tried again next time
    rows: int = 0  # in results.parquet


def sweep(
    spec: SweepSpec, cells: list[Cell], out: Path, console: Console, scheduler: str | None = None,
    workers: int | None = None, keep_runs: bool = False, processes: bool = True, runner: CellRunner = run_cell,
) -> SweepOutcome:
    """Run what is missing of `cells` into `out` and write the results of every finished one.

    `processes=False` runs a local cluster's workers as threads of this process (tests); `runner`: what a
    worker does with a cell (`cluster.run_cells`)."""
    done = store.finished(out)
    todo = [c for c in cells if c.key not in done]
    outcome = SweepOutcome(len(cells), len(cells) - len(todo))
    store.write_sweep(out, spec, cells)
    console.print(f"{spec.name}: {len(cells)} missions, {outcome.skipped} already in {out}, {len(todo)} to run")
    if todo:
        started = time.perf_counter()
        runs_dir = str((out / "runs").resolve()) if keep_runs else None
        with dask_client(scheduler, workers, processes) as client:
            console.print(f"on {describe(client)}")
            if scheduler is not None:  # workers elsewhere: a strategy file goes to them
                todo = ship_strategies(client, todo)
            ran = run_cells(client, todo, runs_dir, lambda cell, result: store.write_cell(out, cell, result), console,
                            runner)
        outcome.ran, outcome.failed = ran.ran, ran.failed
        console.print(f"ran {ran.ran} missions in {time.perf_counter() - started:.0f} s"
                      + (f", {len(ran.failed)} failed" if ran.failed else ""))
    _write_failures(out, outcome.failed, console)
    failed = {f.cell.key for f in outcome.failed}
    finished = [c for c in cells if c.key not in failed]
    if finished:
        outcome.rows = len(store.write_results(out, finished, spec.swept))
        console.print(f"{outcome.rows} rows in {out / 'results.parquet'} and {out / 'results.csv'}")
    return outcome


def _write_failures(out: Path, failed: list[Failure], console: Console) -> None:
    """Each failed mission in a line on the console; with its traceback in DIR/failed.txt."""
    path = out / FAILED
    if not failed:
        path.unlink(missing_ok=True)
        return
    for f in failed:
        console.print(f"[red]failed[/] {f.cell.label}: {f.why}")
    with store.atomic(path) as tmp:
        tmp.write_text("".join(f"{f.cell.label} (cell {f.cell.key}):\n{f.trace}\n" for f in failed), encoding="utf-8")
    console.print(f"tracebacks in {path}")
