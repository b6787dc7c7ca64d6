"""`vil gcs` and `vil replay`: arguments and start-up of the console apps.

    vil gcs --sitl                                   # demo: embedded SITL aPad, pool12
    vil gcs --connect udp:127.0.0.1:14550 --scenario missions/pool12.toml
    vil replay runs/latest --speed 16                # the last run; or runs/pool12-cautious-seed1-run1

Everything `vil gcs` is given (scenario and its files, address, output folder) is opened before the
console starts: what it cannot use is one line on stderr and exit 2, never a console that hangs.
Textual is imported only when a console starts, so other subcommands start fast.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path

from gcs.mission import flags
from gcs.mission.scenario import MAX_DURATION_S, MISSIONS_DIR, ScenarioError, load_scenario
from gcs.records import rundirs
from mavlink_dialect.signing import SigningKeyError, load_key

DEFAULT_SCENARIO = MISSIONS_DIR / "pool12.toml"
SPEED_RANGE = (0.1, 1000.0)  # x real time, for a paced SITL world and for replays


def add_gcs_arguments(parser: argparse.ArgumentParser) -> None:
    link = parser.add_mutually_exclusive_group(required=True)
    link.add_argument("--connect", metavar="ADDR[,ADDR...]",
                      help="the aPad(s) at udp:HOST:PORT (or tcp:, serial:); several addresses comma-separated")
    link.add_argument("--sitl", action="store_true", help="embed a SITL aPad (no other process needed)")
    parser.add_argument("--sitl-link", choices=("memory", "udp"), default="memory",
                        help="with --sitl: in-memory pair or a localhost UDP socket (real MAVLink bytes either way)")
    parser.add_argument("--scenario", metavar="FILE", help=f"scenario TOML (default {DEFAULT_SCENARIO.name})")
    parser.add_argument("--speed", type=flags.number_in(*SPEED_RANGE), metavar="X",
                        help="with --sitl: run the world X times faster than real time (lockstep, deterministic; "
                             f"{SPEED_RANGE[0]:g} to {SPEED_RANGE[1]:g})")
    parser.add_argument("--out", type=flags.writable_dir, metavar="DIR",
                        help="write gcs.tlog and events.jsonl here (default: a new runs/console-NAME-runK, "
                             "and runs/latest points at it)")
    parser.add_argument("--paused", action="store_true", help="start with the scenario loop paused")
    parser.add_argument("--signing-key", type=Path, metavar="FILE",
                        help="MAVLink 2 signing with the passphrase in FILE (default: $VIL_SIGNING_KEY if set); "
                             "the aPad's unsigned frames are then refused")


def run_gcs(args: argparse.Namespace) -> int:
    from gcs.console.app import LiveConsole
    from gcs.console.runner import ConsoleConfig, ConsoleRunner, open_world
    from gcs.mission.scenario_models import check_inputs

    path = Path(args.scenario) if args.scenario else DEFAULT_SCENARIO
    try:
        scenario = load_scenario(path)
        check_inputs(scenario)
        key = load_key(args.signing_key)
    except (ScenarioError, OSError, SigningKeyError) as exc:
        print(f"vil gcs: {exc}", file=sys.stderr)
        return 2
    if args.speed is not None and not args.sitl:
        print("vil gcs: --speed needs --sitl (a real aPad runs in real time)", file=sys.stderr)
        return 2
    try:
        out = args.out or rundirs.new_run_dir(Path("runs"), f"console-{scenario.name}")
        out.mkdir(parents=True, exist_ok=True)
        (out / "console.json").write_text(json.dumps({"scenario": scenario.name,
                                                      "scenario_path": str(path.resolve())}))
    except OSError as exc:
        print(f"vil gcs: cannot write the logs in {args.out or 'runs'}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    config = ConsoleConfig(
        scenario, connect=args.connect, sitl=args.sitl_link if args.sitl else None, speed=args.speed,
        out_dir=out, start_paused=args.paused, signing_key=key,
    )
    try:  # open everything now: what cannot be used is refused before the console starts
        world = open_world(config)
    except (OSError, ValueError) as exc:  # AddressError is a ValueError
        if args.out is None:
            shutil.rmtree(out, ignore_errors=True)  # the folder made for this run holds nothing
        print(f"vil gcs: {exc}", file=sys.stderr)
        return 2
    if args.out is None:
        rundirs.point_latest(out)
    runner = ConsoleRunner(config, world)
    LiveConsole(runner).run()
    runner.request_quit()
    runner.finished.wait(timeout=QUIT_TIMEOUT_S)
    if runner.error:
        print(f"vil gcs: {runner.error}", file=sys.stderr)
        return 1
    print(f"vil gcs: logs in {out} (replay: vil replay {out})")
    return 0


QUIT_TIMEOUT_S = 150.0


def add_replay_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("run", metavar="RUN_DIR_OR_TLOG",
                        help="a run folder (gcs.tlog, events.jsonl; runs/latest: the last run) or a .tlog")
    parser.add_argument("--scenario", metavar="FILE", help="scenario TOML for the area and thresholds "
                                                           "(default: the one the run names)")
    parser.add_argument("--speed", type=flags.number_in(*SPEED_RANGE), default=8.0,
                        help=f"playback speed, x real time ({SPEED_RANGE[0]:g} to {SPEED_RANGE[1]:g}, default 8)")
    parser.add_argument("--start", type=flags.number_in(0.0, MAX_DURATION_S), default=0.0, metavar="S",
                        help="start at this mission time")
    parser.add_argument("--paused", action="store_true", help="start paused")


def run_replay(args: argparse.Namespace) -> int:
    from gcs.console.app import ReplayConsole
    from gcs.records.replay import ReplayError, load_replay

    try:
        replay = load_replay(args.run, args.scenario)
    except (ReplayError, ScenarioError, OSError) as exc:
        print(f"vil replay: {exc}", file=sys.stderr)
        return 2
    ReplayConsole(replay, start_s=args.start, playing=not args.paused, speed=args.speed).run()
    return 0
