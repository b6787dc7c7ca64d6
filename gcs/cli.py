"""`vil`: the command line. Each subcommand's module adds its arguments and runs it.

Only the chosen subcommand's module is imported (the others bring MAVLink, numpy and Textual
with them), so `vil --help` answers at once.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.metadata
import sys
from collections.abc import Callable, Sequence
from typing import NamedTuple

Runner = Callable[[argparse.Namespace], int]


class Command(NamedTuple):
    name: str
    summary: str  # one line in `vil --help`
    module: str  # defines the two functions below; its docstring is the command's description
    add_arguments: str
    run: str


# The whole command line in one table.
COMMANDS = (
    Command("run", "headless mission(s) in lockstep; no scenario: the paper's Table II reproduction",
            "gcs.mission.run_cli", "add_arguments", "run"),
    Command("sitl", "the SITL aPad alone, in real time, on UDP/TCP/serial (--scenario: its aPads)",
            "gcs.mission.sitl_cli", "add_arguments", "run"),
    Command("gcs", "the operator console, live against an aPad (--sitl embeds one)",
            "gcs.console.cli", "add_gcs_arguments", "run_gcs"),
    Command("replay", "the console driven from a recorded run", "gcs.console.cli", "add_replay_arguments",
            "run_replay"),
    Command("report", "plots, HTML summary and GeoJSON of a recorded run", "gcs.records.report", "add_arguments",
            "run"),
    Command("sweep", "many headless missions over strategies, seeds and scenario fields, on Dask", "gcs.sweep.cli",
            "add_arguments", "run"),
)


def build_parser(argv: Sequence[str]) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="vil",
        description="Vehicle-in-the-loop ground-control station for an aPad / aMussel marine robot swarm.",
        epilog="vil COMMAND --help explains each command.",
    )
    parser.add_argument("--version", action="version", version=f"vil {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    chosen = next((a for a in argv if not a.startswith("-")), None)
    for command in COMMANDS:
        if command.name != chosen:
            sub.add_parser(command.name, help=command.summary)
            continue
        module = importlib.import_module(command.module)
        parser_ = sub.add_parser(command.name, help=command.summary, description=module.__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
        getattr(module, command.add_arguments)(parser_)
        parser_.set_defaults(runner=getattr(module, command.run))
    return parser


def _version() -> str:
    """The installed distribution's version (a source tree that was never installed: unknown)."""
    try:
        return importlib.metadata.version("vil")
    except importlib.metadata.PackageNotFoundError:
        return "unknown (not installed)"


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser(argv).parse_args(argv)
    args.argv = argv  # the command line as given (`vil gcs --web` serves the same one to browsers)
    runner: Runner = args.runner
    return runner(args)


if __name__ == "__main__":
    sys.exit(main())
