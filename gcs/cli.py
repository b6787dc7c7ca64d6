"""`vil`: the command line. Each subcommand's module adds its arguments and runs it."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence

from apad_sitl import serve
from gcs import run_cli

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
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    runner: Runner = args.runner
    return runner(args)


if __name__ == "__main__":
    sys.exit(main())
