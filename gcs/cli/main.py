"""`vil`: the command line. Each subcommand's module adds its arguments and runs it.

Only the chosen subcommand's module is imported (the others bring MAVLink, numpy and Textual
with them), so `vil --help` answers at once.
"""

from __future__ import annotations

import argparse
import difflib
import importlib
import importlib.metadata
import sys
from collections.abc import Callable, Sequence
from typing import NamedTuple, NoReturn

Runner = Callable[[argparse.Namespace], int]


class OneLineParser(argparse.ArgumentParser):
    """A bad flag is one line, not a usage block: what is wrong, a close flag where one is obvious
    (a misspelling), and where the flags are explained."""

    def error(self, message: str) -> NoReturn:
        hint = f" ({self.prog} --help explains every flag)"
        self.exit(2, f"{self.prog}: error: {message}{self.suggestion(message)}{hint}\n")

    def suggestion(self, message: str) -> str:
        """"; did you mean --strategy?" for an unknown flag close to one of this parser's."""
        if not message.startswith("unrecognized arguments:"):
            return ""
        unknown = [a.split("=")[0] for a in message.split(":", 1)[1].split() if a.startswith("--")]
        # argparse keeps its option strings in a private table; there is no public read of them.
        known = [o for o in self._option_string_actions if o.startswith("--")]
        for flag in unknown:
            close = difflib.get_close_matches(flag, known, n=1, cutoff=0.6)
            if close:
                return f"; did you mean {close[0]}?"
        return ""


class Command(NamedTuple):
    name: str
    summary: str  # one line in `vil --help`
    module: str  # defines the two functions below; its docstring is the command's description
    add_arguments: str
    run: str


# The whole command line in one table.
COMMANDS = (
    Command("run", "headless mission(s) in lockstep; no scenario: the paper's Table II reproduction",
            "gcs.cli.run", "add_arguments", "run"),
    Command("sitl", "the SITL aPad alone, in real time, on UDP/TCP/serial (--scenario: its aPads)",
            "gcs.cli.sitl", "add_arguments", "run"),
    Command("gcs", "the operator console, live against an aPad (--sitl embeds one)",
            "gcs.cli.console", "add_gcs_arguments", "run_gcs"),
    Command("replay", "the console driven from a recorded run", "gcs.cli.replay", "add_arguments", "run"),
    Command("report", "plots, HTML summary and GeoJSON of a recorded run", "gcs.cli.report", "add_arguments",
            "run"),
    Command("sweep", "many headless missions over strategies, seeds and scenario fields, on Dask", "gcs.cli.sweep",
            "add_arguments", "run"),
    Command("tune", "search a policy's parameters and sleep schedule for an objective (Optuna, on Dask)",
            "gcs.cli.tune", "add_arguments", "run"),
    Command("scenario", "check scenario files (schema and reader), or write a new one from an area",
            "gcs.cli.scenario", "add_arguments", "run"),
    Command("modem", "a nanomodem v3 emulated on a pty (or serial device) over the acoustic channel model",
            "gcs.cli.modem", "add_arguments", "run"),
)


def build_parser(argv: Sequence[str]) -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog="vil",
        description="Vehicle-in-the-loop ground-control station for an aPad / aMussel marine robot swarm.",
        epilog="vil COMMAND --help explains each command.",
    )
    parser.add_argument("--version", action="version", version=f"vil {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    chosen = next((a for a in argv if not a.startswith("-")), None)
    parser.set_defaults(chosen=None)
    for command in COMMANDS:
        if command.name != chosen:
            sub.add_parser(command.name, help=command.summary)
            continue
        module = importlib.import_module(command.module)
        parser_ = sub.add_parser(command.name, help=command.summary, description=module.__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
        getattr(module, command.add_arguments)(parser_)
        parser_.set_defaults(runner=getattr(module, command.run), chosen=parser_)
    return parser


def _version() -> str:
    """The installed distribution's version (a source tree that was never installed: unknown)."""
    try:
        return importlib.metadata.version("vil")
    except importlib.metadata.PackageNotFoundError:
        return "unknown (not installed)"


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(argv)
    args, extra = parser.parse_known_args(argv)
    if extra:  # reported by the command's own parser: its name, and its flags to suggest from
        (args.chosen or parser).error(f"unrecognized arguments: {' '.join(extra)}")
    del args.chosen
    args.argv = argv  # the command line as given (`vil gcs --web` serves the same one to browsers)
    runner: Runner = args.runner
    return runner(args)


if __name__ == "__main__":
    sys.exit(main())
