"""`vil sweep`: many headless missions over scenarios, strategies, seeds and scenario fields, on Dask.

    vil sweep missions/sweeps/strategies.toml --out sweeps/strategies   # every strategy, pool12 + bay24
    vil sweep SPEC.toml --out DIR --scheduler tcp://HOST:8786           # on a running Dask cluster
    vil sweep report DIR                                                # tables and plots again
    vil sweep missions/sweeps/quick.toml --out sweeps/quick             # a first try: a minute on 2 cores

The spec (TOML; docs/sweeps.md) is checked whole before anything runs. Each mission runs in
lockstep as `vil run` runs it and writes DIR/cells/KEY.json when it finishes; a mission already
there is not run again, so an interrupted sweep continues where it stopped. At the end:
DIR/results.parquet and DIR/results.csv (one row per mission), DIR/active.parquet (active count
over mission time) and the report in DIR/report/.

Exit status: 0 done; 1 some missions failed (listed; run again to retry them); 2 bad input.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import IO, cast

from rich.console import Console

from gcs.cli import flags
from gcs.cli.tables import output_console
from gcs.sweep import store
from gcs.sweep.cells import make_cells
from gcs.sweep.cluster import ClusterError
from gcs.sweep.runner import sweep
from gcs.sweep.spec import MAX_CELLS, SpecError, load_spec

MAX_WORKERS = 256
EXIT_FAILED, EXIT_BAD_INPUT, EXIT_INTERRUPTED = 1, 2, 130


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.usage = "vil sweep SPEC.toml --out DIR [--seeds N] [options]\n       vil sweep report DIR"
    parser.add_argument("spec", metavar="SPEC.toml | report", help="the sweep spec, or `report` to report on DIR")
    parser.add_argument("dir", nargs="?", metavar="DIR", help="with `report`: the sweep folder")
    parser.add_argument("--out", type=flags.writable_dir, metavar="DIR",
                        help="required with SPEC.toml: the sweep folder: finished missions, results.parquet/csv, "
                             "report/")
    parser.add_argument("--seeds", type=flags.integer_in(1, MAX_CELLS), metavar="N",
                        help="only the spec's first N seeds (a quick try of a big spec; the same cells as the "
                             "whole spec's, so a later run of all of them keeps these)")
    parser.add_argument("--base-samples", type=flags.integer_in(1, 65_536), metavar="N",
                        help="a [sensitivity] study on its first N base samples (a power of 2 for Sobol): the same "
                             "missions as the whole study's first, so a later run of all of them keeps these")
    parser.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                        help="run on this Dask scheduler's workers (default: a local cluster, a worker per core)")
    parser.add_argument("--workers", type=flags.integer_in(1, MAX_WORKERS), metavar="N",
                        help="workers of the local cluster (default: CPU count)")
    parser.add_argument("--keep-runs", action="store_true",
                        help="keep each mission's folder (.tlog, logs, traces) in DIR/runs/ (default: none written)")
    parser.add_argument("--no-report", action="store_true", help="skip the tables and plots at the end")


def run(args: argparse.Namespace) -> int:
    console = output_console()
    lines = LineEnds(console.file)
    console.file = cast(IO[str], lines)
    if args.spec == "report":
        return _report(args.dir, console)
    if args.dir is not None:
        return _bad(f"unexpected argument {args.dir!r} (the folder is --out DIR)")
    if args.out is None:
        return _bad("--out DIR is required: where the missions and results go")
    if args.scheduler is not None and args.workers is not None:
        return _bad("--workers sizes the local cluster; with --scheduler the cluster has its own")
    try:
        spec = load_spec(args.spec)
        if args.seeds is not None:
            spec = spec.first_seeds(args.seeds)
        if args.base_samples is not None:
            spec = spec.first_base_samples(args.base_samples)
        cells = make_cells(spec)
    except SpecError as exc:
        return _bad(str(exc))
    try:
        outcome = sweep(spec, cells, args.out, console, args.scheduler, args.workers, args.keep_runs)
    except OSError as exc:  # the folder went away or filled up
        return _bad(f"--out {args.out}: {exc.strerror or exc}")
    except ClusterError as exc:
        print(f"vil sweep: {exc}", file=sys.stderr)
        return EXIT_FAILED
    except KeyboardInterrupt:
        kept = len(store.finished(args.out) & {c.key for c in cells})
        lines.end_line()  # a progress line cut short (output to a file or a pipe) is not the message's start
        print(f"vil sweep: interrupted; {kept} of {len(cells)} missions are in {args.out}: run it again to continue",
              file=sys.stderr)
        return EXIT_INTERRUPTED
    if outcome.rows and not args.no_report:
        _report(str(args.out), console)
    return EXIT_FAILED if outcome.failed else 0


class LineEnds:
    """The console's output, remembering whether its last line was ended, so a message on stderr after an
    interruption starts a line of its own when both go to one file."""

    def __init__(self, out: IO[str]) -> None:
        self.out = out
        self.ended = True
        self.encoding: str = getattr(out, "encoding", None) or "utf-8"  # rich draws ASCII boxes where not UTF-8

    def write(self, text: str) -> int:
        if text:
            self.ended = text.endswith("\n")
        return self.out.write(text)

    def flush(self) -> None:
        self.out.flush()

    def isatty(self) -> bool:
        return self.out.isatty()

    def fileno(self) -> int:
        return self.out.fileno()

    def end_line(self) -> None:
        if not self.ended:
            self.write("\n")
        self.flush()


def _report(folder: str | None, console: Console) -> int:
    if folder is None:
        return _bad("report needs the sweep folder: vil sweep report DIR")
    from gcs.sweep.findings import ReportError, write_report  # matplotlib only when reporting

    try:
        written = write_report(Path(folder), console)
    except (ReportError, store.StoreError) as exc:
        return _bad(str(exc))
    console.print(f"report: {', '.join(str(p) for p in written)}")
    return 0


def _bad(what: str) -> int:
    print(f"vil sweep: {what}", file=sys.stderr)
    return EXIT_BAD_INPUT
