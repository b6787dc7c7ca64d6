"""`vil`: the command line. Each subcommand's module adds its arguments and runs it."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence

from apad_sitl import serve
from gcs import report, run_cli
from gcs.tui import cli as console_cli

Runner = Callable[[argparse.Namespace], int]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="vil",
        description="Vehicle-in-the-loop ground-control station for an aPad / aMussel marine robot swarm.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    run_p = sub.add_parser(
        "run",
        help="headless mission(s) in lockstep; no scenario: the paper's Table II reproduction",
        description=run_cli.__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    run_cli.add_arguments(run_p)
    run_p.set_defaults(runner=run_cli.run)
    sitl = sub.add_parser(
        "sitl",
        help="the SITL aPad alone, in real time, on UDP/TCP/serial",
        description="Run the SITL kinematic aPad as a MAVLink vehicle in real time.",
    )
    serve.add_arguments(sitl)
    sitl.set_defaults(runner=serve.run)
    gcs = sub.add_parser(
        "gcs",
        help="the operator console, live against an aPad (--sitl embeds one)",
        description=console_cli.__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    console_cli.add_gcs_arguments(gcs)
    gcs.set_defaults(runner=console_cli.run_gcs)
    replay = sub.add_parser("replay", help="the console driven from a recorded run",
                            description="Replay a recorded run in the console: play, pause, speed, seek.")
    console_cli.add_replay_arguments(replay)
    replay.set_defaults(runner=console_cli.run_replay)
    report_p = sub.add_parser("report", help="plots, HTML summary and GeoJSON of a recorded run",
                              description=report.__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    report.add_arguments(report_p)
    report_p.set_defaults(runner=report.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    runner: Runner = args.runner
    return runner(args)


if __name__ == "__main__":
    sys.exit(main())
