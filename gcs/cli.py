"""`vil`: the command line. Each subcommand's module adds its arguments and runs it."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence

from apad_sitl import serve

Runner = Callable[[argparse.Namespace], int]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="vil",
        description="Vehicle-in-the-loop ground-control station for an aPad / aMussel marine robot swarm.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
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
