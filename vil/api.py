"""The calls of the `vil` package: each the same mission, folder and checks as its command."""

from __future__ import annotations

import inspect
import json
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import pandas as pd
from rich.console import Console

from gcs.mission.checkpoint import CheckpointError
from gcs.mission.start import RUNS, prepare_run, run_prepared
from gcs.records.run_folder import RunFolder
from gcs.scenario.reader import (
    Scenario,
    ScenarioError,
    load_scenario,
    read_toml,
    resolve_scenario,
    scenario_from_data,
)
from gcs.sweep.cells import make_cells, patched
from gcs.sweep.cluster import ClusterError
from gcs.sweep.runner import sweep as run_sweep
from gcs.sweep.spec import SpecError, load_spec
from vil.main_guard import ADVICE, unguarded_call
from vil.options import ApadAt, Seconds, Window, run_options
from vil.result import Result


class Error(ValueError):
    """Input the mission cannot run with (one line: what and where)."""


def scenario(name: str | Path = "pool12", fields: dict[str, Any] | None = None) -> Scenario:
    """A scenario by file or shipped name, with `fields` ("table.field": value, as a sweep's) changed.
    The variant is checked as a file would be: a wrong field or value is an `Error` naming it."""
    try:
        path = resolve_scenario(name)
        return scenario_from_data(path, patched(read_toml(path), fields)) if fields else load_scenario(path)
    except ScenarioError as exc:
        raise Error(str(exc)) from None


def run(
    of: str | Path | Scenario = "pool12", *, strategy: str | None = None, seed: int | None = None,
    duration: Seconds | None = None, theta: float | None = None, draw_fleet: bool = False,
    loss: float = 0.0, latency: Seconds = 0.0, jitter: Seconds = 0.0, duplicate: float = 0.0,
    outages: Iterable[Window] = (), fail_apads: Iterable[ApadAt] = (), proxy: bool = False,
    signing_key: str | Path | None = None, resume: bool = False, out: str | Path = RUNS,
    platform: str = "lockstep",
) -> Result:
    """One mission, as `vil run` runs it with the same flags (same figures), in a new folder
    `out/SCENARIO-STRATEGY-seedN-runK` (`latest` points at it). Lengths of time are seconds or strings
    with their unit ("40m", "24h", "200ms").

    Link faults put the aPad link over real UDP through a seeded proxy: `loss` and `duplicate` are
    fractions, `latency` and `jitter` one-way delays, `outages` windows of total loss ("92s:112s" or
    (92, 112)), `fail_apads` aPads silent for good from a time ("3:10min" or (3, 600)); `proxy` routes
    through it with no faults. `signing_key` signs the link: a passphrase (str) or a key file (Path);
    None: $VIL_SIGNING_KEY if set, as `vil run`. `resume`: continue the newest folder of this run that
    holds a checkpoint (after a crash), with the options it was started with. `platform`: "lockstep"
    (every MAVLink byte on the wire, the reference) or "event" (discrete events over an ideal link, no .tlog;
    3 to 8 times as fast so far; the wire's options are refused there: docs/platforms.md).
    """
    base = of if isinstance(of, Scenario) else scenario(of)
    given: dict[str, Any] = dict(
        strategy=strategy, seed=seed, duration=duration, theta=theta, draw_fleet=draw_fleet, loss=loss,
        latency=latency, jitter=jitter, duplicate=duplicate, outages=tuple(outages), fail_apads=tuple(fail_apads),
        proxy=proxy, platform=platform,
    )
    try:
        options = run_options(**given, signing_key=signing_key, resume=resume, out=out)
        prepared = prepare_run(base, options, _command(base, given, signing_key, out), _say)
    except (ValueError, CheckpointError) as exc:  # ScenarioError, StrategyError, SigningKeyError are ValueErrors
        raise Error(str(exc)) from None
    except OSError as exc:  # the output folder cannot be made or written
        raise Error(f"out {out}: {exc.strerror or exc}") from None
    try:
        run_prepared(prepared)
    except TimeoutError as exc:  # e.g. an outage over the start: the aPad was never heard
        raise Error(str(exc)) from None
    return Result.read(RunFolder(prepared.out_dir))


def _command(s: Scenario, given: dict[str, Any], signing_key: str | Path | None, out: str | Path) -> str:
    """The call that made a run, for its command.txt (what resumes it, with resume=True): the
    arguments given other than their defaults; a passphrase stays out of it (give it again). A scenario
    changed in Python (`scenario(..., fields=...)`) is no file a call can name: the line says so, and
    resuming asks for the same scenario object and options."""
    defaults = {k: p.default for k, p in inspect.signature(run).parameters.items()}
    args = [f"{k}={v!r}" for k, v in given.items() if v != defaults[k] and v != ()]
    args += [f"signing_key=Path({str(signing_key)!r})"] if isinstance(signing_key, Path) else []
    args += [f"out={str(out)!r}"] if Path(out) != RUNS else []
    call = f"vil.run({', '.join([json.dumps(str(s.path)), *args])})"
    return call if s == load_scenario(s.path) else f"# {call} with the scenario changed in Python"


def _say(line: str) -> None:
    print(f"vil.run: {line}", file=sys.stderr)


def load(run_folder: str | Path) -> Result:
    """A recorded run (a folder `vil run`, `vil.run` or the console wrote; `runs/latest` too)."""
    folder = RunFolder.at(run_folder)
    if not folder.result.is_file():
        raise Error(f"{folder.path}: no {folder.result.name} (a run still going, or not a run folder)")
    return Result.read(folder)


def sweep(spec: str | Path, out: str | Path, *, scheduler: str | None = None, workers: int | None = None,
          quiet: bool = True) -> pd.DataFrame:
    """The missions of a sweep spec on Dask (a local cluster, or `scheduler`'s), those already in
    `out` kept; one row per mission, as `out/results.parquet` (docs/sweeps.md).

    A local cluster's workers are spawned processes that import the calling script again, so in a
    script call it under `if __name__ == "__main__":` (a notebook needs nothing); unguarded, it is
    an `Error` saying so before any process starts."""
    unguarded = unguarded_call() if scheduler is None else None
    if unguarded is not None:
        raise Error(ADVICE.format(file=unguarded[0], line=unguarded[1]))
    try:
        loaded = load_spec(spec)
        cells = make_cells(loaded)
        outcome = run_sweep(loaded, cells, Path(out), Console(quiet=quiet), scheduler, workers)
    except (SpecError, ClusterError) as exc:
        raise Error(str(exc)) from None
    if outcome.failed:
        raise Error(f"{len(outcome.failed)} of {outcome.cells} missions failed: {outcome.failed[0].why} "
                    f"(tracebacks in {Path(out) / 'failed.txt'})")
    return pd.read_parquet(Path(out) / "results.parquet")
