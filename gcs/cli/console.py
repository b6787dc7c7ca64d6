"""`vil gcs`: the operator console, live against an aPad: a running one (--connect) or one it embeds (--sitl).

    vil gcs --sitl                                   # demo: embedded SITL aPad, pool12
    vil gcs --sitl --scenario missions/pool12x2.toml # two aPads: `a` picks the one the keys command
    vil gcs --connect udp:127.0.0.1:14550 --scenario missions/pool12.toml
    vil gcs --sitl --resume                          # continue the console mission that crashed
    vil gcs --sitl --web 8000                        # the same console in a browser: http://127.0.0.1:8000/
    vil gcs --sitl --web 0.0.0.0:8000                # for the boat's network, behind a token: open the
                                                     #   printed http://ADDRESS:8000/?token=... (403 without it)

Everything `vil gcs` is given (scenario and its files, address, output folder) is opened before the
console starts: what it cannot use is one line on stderr and exit 2, never a console that hangs.
"""
# Textual is imported only when a console starts, so other subcommands start fast.

from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from acoustic.nanomodem.sea import parse_udp
from gcs.cli import flags
from gcs.console.web import TOKEN_ENV, WebTokenError, read_web_token, serve_console, web_address
from gcs.records.run_folder import RunFolder
from gcs.scenario.reader import MISSIONS_DIR, Scenario, ScenarioError, load_scenario, resolve_scenario
from gcs.strategies import StrategyError, source_of
from mavlink_dialect.signing import SigningKeyError, load_key
from missiontime import unix_time_us

if TYPE_CHECKING:
    from gcs.console.runner import ResumePoint

DEFAULT_SCENARIO = MISSIONS_DIR / "pool12.toml"
SPEED_RANGE = (0.1, 1000.0)  # x real time, for a paced SITL world and for replays (gcs/cli/replay.py)


def add_gcs_arguments(parser: argparse.ArgumentParser) -> None:
    link = parser.add_mutually_exclusive_group()  # one of them is needed: run_gcs says so, suggesting --sitl
    link.add_argument("--connect", metavar="ADDR[,ADDR...]",
                      help="the aPad(s) at udp:HOST:PORT (or tcp:, serial:); several addresses comma-separated")
    link.add_argument("--sitl", action="store_true", help="embed a SITL aPad (no other process needed)")
    parser.add_argument("--sitl-link", choices=("memory", "udp"), default="memory",
                        help="with --sitl: in-memory pair or a localhost UDP socket (real MAVLink bytes either way)")
    parser.add_argument("--scenario", metavar="FILE", help=f"scenario TOML (default {DEFAULT_SCENARIO.name})")
    parser.add_argument("--strategy", metavar="NAME",
                        help="collection strategy (default: the scenario's): a shipped one, FILE.py:FUNCTION, "
                             "MODULE:FUNCTION or an installed vil.strategies entry point (docs/strategies.md); "
                             "the s key cycles through the shipped ones and it")
    parser.add_argument("--speed", type=flags.number_in(*SPEED_RANGE), metavar="X",
                        help="with --sitl: run the world X times faster than real time (lockstep, deterministic; "
                             f"{SPEED_RANGE[0]:g} to {SPEED_RANGE[1]:g})")
    parser.add_argument("--out", type=flags.writable_dir, metavar="DIR",
                        help="write gcs.tlog and events.jsonl here (default: a new runs/console-NAME-runK, "
                             "and runs/latest points at it)")
    parser.add_argument("--paused", action="store_true", help="start with the scenario loop paused")
    parser.add_argument("--resume", action="store_true",
                        help="continue the mission of a console that crashed, from its last checkpoint: the "
                             "newest runs/console-NAME-runK holding one (or --out DIR); docked aMussels are not "
                             "called up again")
    parser.add_argument("--signing-key", type=Path, metavar="FILE",
                        help="MAVLink 2 signing with the passphrase in FILE (default: $VIL_SIGNING_KEY if set); "
                             "the aPad's unsigned frames are then refused")
    parser.add_argument("--web", type=web_address, metavar="[HOST:]PORT",
                        help="serve this console to browsers (a tablet on deck) instead of this terminal: each "
                             "browser session runs it with these same arguments, one at a time; HOST default "
                             "127.0.0.1 (this machine only), 0.0.0.0 for every network. Bound to anything but "
                             "loopback, a random token is made at start and the printed address carries it "
                             "(http://HOST:PORT/?token=...): without it, from any peer, the page and its websocket "
                             "answer 403; a browser that opened that address once keeps a cookie")
    parser.add_argument("--web-token-file", type=Path, metavar="FILE",
                        help=f"with --web: the token is FILE's first line instead of a random one (default: "
                             f"${TOKEN_ENV} if set); a given token is asked for on loopback too")
    parser.add_argument("--modem", metavar="DEVICE",
                        help="the GCS's nanomodem on this serial device (a path or pyserial URL, 9600 8N1): a real "
                             "unit, or `vil modem`'s pty; submerged aMussels are heard and called up through it "
                             "(needs a scenario with [acoustic] enabled; docs/acoustic.md)")
    parser.add_argument("--sea", metavar="udp:HOST:PORT",
                        help="with --modem: where `vil modem --sea` listens for the simulated aMussels' modems; "
                             "without it they are not on the water (only real aMussels are heard)")
    parser.add_argument("--bridge", metavar="ADDR",
                        help="listen here (udp:HOST:PORT or serial:DEV[:BAUD]) for real aMussels' AMUSSEL_STATUS "
                             "reports; they join the simulated fleet (the scenario's fleet.real_ids)")


def modem_refusal(modem: str | None, sea: str | None, speed: float | None, acoustic: bool, name: str) -> str:
    """Why --modem/--sea cannot be used as given, or "" (one line for the user)."""
    if modem is None:
        return "--sea needs --modem (the simulated aMussels share the water with the GCS's unit)" if sea else ""
    if not acoustic:
        return f"--modem needs a scenario with [acoustic] enabled ({name} has none: e.g. missions/pool12-acoustic.toml)"
    if speed is not None:
        return "--modem runs in real time: the unit on the serial port keeps the wall clock (drop --speed)"
    if sea is not None:
        try:
            parse_udp(sea)
        except ValueError as exc:
            return f"--sea: {exc}"
    return ""


def run_gcs(args: argparse.Namespace) -> int:
    from gcs.mission.start import RunOptions, check_start, check_strategy, variant

    if not args.connect and not args.sitl:
        print("vil gcs: which aPad? --sitl for a first look (an embedded SITL aPad, no other process), or "
              "--connect udp:HOST:PORT for a running one", file=sys.stderr)
        return 2
    try:
        path = resolve_scenario(args.scenario or DEFAULT_SCENARIO)
        base = load_scenario(path)
        check_start(base, RunOptions())
        scenario = variant(base, RunOptions(strategy=args.strategy))
        check_strategy(scenario)  # a strategy from outside plans once on the start here
        key = load_key(args.signing_key)
        web_token = read_web_token(args.web_token_file) if args.web is not None else None
    except (ScenarioError, OSError, SigningKeyError, WebTokenError, StrategyError) as exc:
        print(f"vil gcs: {exc}", file=sys.stderr)
        return 2
    if args.web_token_file is not None and args.web is None:
        print("vil gcs: --web-token-file needs --web (the token guards the browser console)", file=sys.stderr)
        return 2
    if args.speed is not None and not args.sitl:
        print("vil gcs: --speed needs --sitl (a real aPad runs in real time)", file=sys.stderr)
        return 2
    refused = modem_refusal(args.modem, args.sea, args.speed, scenario.acoustic.enabled, scenario.name)
    if refused:
        print(f"vil gcs: {refused}", file=sys.stderr)
        return 2
    if args.web is not None:  # checked as above; each browser session then runs the console itself
        host, port = args.web
        return serve_console(getattr(args, "argv", sys.argv[1:]), host, port, title=f"vil gcs: {scenario.name}",
                             given_token=web_token)
    # Imported here: `--web` serves the console from its sessions' processes, not this one (~1.5 s saved).
    from gcs.console.app import QUIT_BOUND_S, LiveConsole
    from gcs.console.runner import ConsoleConfig, ConsoleRunner, open_world
    from gcs.mission.checkpoint import CheckpointError

    stem = f"console-{scenario.name}"
    if args.resume:
        try:
            if args.strategy is None:  # the strategy the mission ran with (one from a file is loaded again)
                scenario = _saved_strategy(args.out, stem, scenario)
            out, epoch_us, resume = _resume_point(args.out, stem, scenario)
        except (CheckpointError, StrategyError) as exc:
            print(f"vil gcs: {exc}", file=sys.stderr)
            return 2
        if args.speed is None and args.sitl:
            args.speed = saved_speed(RunFolder(out))  # a watched simulation goes on at the pace it had
    else:
        epoch_us, resume = unix_time_us(), None
        try:
            out = args.out or RunFolder.new(Path("runs"), stem).path
            out.mkdir(parents=True, exist_ok=True)
            record = {"scenario": scenario.name, "scenario_path": str(path.resolve()), "epoch_us": epoch_us,
                      "speed": args.speed, "strategy": source_of(scenario.mission.collect_strategy)}
            RunFolder(out).console.write_text(json.dumps(record))
        except OSError as exc:
            print(f"vil gcs: cannot write the logs in {args.out or 'runs'}: {exc.strerror or exc}", file=sys.stderr)
            return 2
    config = ConsoleConfig(
        scenario, connect=args.connect, sitl=args.sitl_link if args.sitl else None, speed=args.speed,
        out_dir=out, start_paused=args.paused, signing_key=key, epoch_us=epoch_us, resume=resume, bridge=args.bridge,
        modem=args.modem, sea=args.sea,
    )
    try:  # open everything now: what cannot be used is refused before the console starts
        world = open_world(config)
        try:
            runner = ConsoleRunner(config, world)  # a resumed mission's state is put back here
        except CheckpointError:
            world.close()
            raise
    except (OSError, ValueError, CheckpointError) as exc:  # AddressError is a ValueError
        if args.out is None and resume is None:
            shutil.rmtree(out, ignore_errors=True)  # the folder made for this run holds nothing
        if resume is not None:
            resume.files.close()
        print(f"vil gcs: {exc}", file=sys.stderr)
        return 2
    if args.out is None:
        RunFolder(out).point_latest()
    LiveConsole(runner).run()
    runner.request_quit(now=True)  # the app has already waited for the world, at most QUIT_BOUND_S
    if not runner.finished.wait(timeout=0.1):
        print(f"vil gcs: the world did not stop within {QUIT_BOUND_S:g} s: the aPads hold by their own failsafe;"
              f" the last events may be missing from {out}", file=sys.stderr)
    if runner.error:
        print(f"vil gcs: {runner.error}", file=sys.stderr)
        return 1
    print(f"vil gcs: logs in {out} (replay: vil replay {out})")
    return 0

def saved_speed(folder: RunFolder) -> float | None:
    """The --speed a console run was started with (console.json), if it was one and the value is sane."""
    try:
        speed = json.loads(folder.console.read_text(encoding="utf-8")).get("speed")
    except (OSError, ValueError, AttributeError):
        return None
    ok = isinstance(speed, int | float) and not isinstance(speed, bool) and SPEED_RANGE[0] <= speed <= SPEED_RANGE[1]
    return float(speed) if ok else None


def _saved_strategy(out: Path | None, stem: str, scenario: Scenario) -> Scenario:
    """`scenario` with the collection strategy console.json says the mission to resume ran with (as
    it is, if it says none: an older run, or none to resume: `_resume_point` says so)."""
    folder = RunFolder(out) if out is not None else RunFolder.newest_resumable(Path("runs"), stem)
    try:
        spec = json.loads(folder.console.read_text(encoding="utf-8")).get("strategy") if folder else None
    except (OSError, ValueError, AttributeError):
        spec = None
    from gcs.mission.start import RunOptions, variant

    return variant(scenario, RunOptions(strategy=spec)) if isinstance(spec, str) and spec else scenario


def _resume_point(out: Path | None, stem: str, scenario: Scenario) -> tuple[Path, int, ResumePoint]:
    """The folder, log epoch and checkpoint of the console mission to resume; `CheckpointError` (one
    line) if there is none or it is unusable. The folder's logs are cut back to the checkpoint."""
    from gcs.console.runner import ResumePoint
    from gcs.mission.checkpoint import (
        CheckpointError,
        CheckpointFiles,
        check_setup,
        cut_logs,
        scenario_key,
        setup_digest,
    )
    from gcs.records.run_folder import CHECKPOINT

    folder = RunFolder(out) if out is not None else RunFolder.newest_resumable(Path("runs"), stem)
    if folder is None:
        raise CheckpointError(f"nothing to resume: no runs/{stem}-runK holds a {CHECKPOINT}")
    files = CheckpointFiles(folder.checkpoint)
    saved = files.read()
    try:
        epoch_us = json.loads(folder.console.read_text(encoding="utf-8"))["epoch_us"]
        if not isinstance(epoch_us, int) or isinstance(epoch_us, bool):
            raise TypeError
    except (OSError, ValueError, KeyError, TypeError):
        raise CheckpointError(f"{folder.console} does not say when the mission began (epoch_us)") from None
    key = scenario_key(scenario)
    if saved.run_key != key:
        raise CheckpointError(f"the checkpoint in {folder.path} is of run {saved.run_key}, not {key}")
    check_setup(saved, setup_digest(scenario))
    cut_logs(folder, saved)  # the stretch after it runs again: each event logged once
    return folder.path, epoch_us, ResumePoint(files, saved)
