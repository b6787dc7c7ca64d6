"""`vil`: the command line. Each subcommand's module adds its arguments and runs it."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence

from apad_sitl import serve
from gcs.console import cli as console_cli
from gcs.mission import run_cli
from gcs.records import report

Runner = Callable[[argparse.Namespace], int]


# name, one-line help, description, add_arguments, runner: the whole command line in one table.
COMMANDS: tuple[tuple[str, str, str | None, Callable[[argparse.ArgumentParser], None], Runner], ...] = (
    ("run", "headless mission(s) in lockstep; no scenario: the paper's Table II reproduction",
     run_cli.__doc__, run_cli.add_arguments, run_cli.run),
    ("sitl", "the SITL aPad alone, in real time, on UDP/TCP/serial",
     "Run the SITL kinematic aPad as a MAVLink vehicle in real time.", serve.add_arguments, serve.run),
    ("gcs", "the operator console, live against an aPad (--sitl embeds one)",
     console_cli.__doc__, console_cli.add_gcs_arguments, console_cli.run_gcs),
    ("replay", "the console driven from a recorded run",
     "Replay a recorded run in the console: play, pause, speed, seek.",
     console_cli.add_replay_arguments, console_cli.run_replay),
    ("report", "plots, HTML summary and GeoJSON of a recorded run", report.__doc__, report.add_arguments, report.run),
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="vil",
        description="Vehicle-in-the-loop ground-control station for an aPad / aMussel marine robot swarm.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, summary, description, add_arguments, runner in COMMANDS:
        command = sub.add_parser(name, help=summary, description=description,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
        add_arguments(command)
        command.set_defaults(runner=runner)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    runner: Runner = args.runner
    return runner(args)


if __name__ == "__main__":
    sys.exit(main())
