"""`vil gcs` and `vil replay`: arguments and start-up of the console apps.

    vil gcs --sitl                                   # demo: embedded SITL aPad, pool12
    vil gcs --connect udp:127.0.0.1:14550 --scenario missions/pool12.toml
    vil replay runs/pool12-cautious-seed1 --speed 16

Textual is imported only when a console starts, so other subcommands start fast.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from gcs.mission.scenario import MISSIONS_DIR, ScenarioError, load_scenario
from mavlink_dialect.signing import SigningKeyError, load_key

DEFAULT_SCENARIO = MISSIONS_DIR / "pool12.toml"


def add_gcs_arguments(parser: argparse.ArgumentParser) -> None:
    link = parser.add_mutually_exclusive_group(required=True)
    link.add_argument("--connect", metavar="ADDR", help="the aPad at udp:HOST:PORT (or tcp:, serial:)")
    link.add_argument("--sitl", action="store_true", help="embed a SITL aPad (no other process needed)")
    parser.add_argument("--sitl-link", choices=("memory", "udp"), default="memory",
                        help="with --sitl: in-memory pair or a localhost UDP socket (real MAVLink bytes either way)")
    parser.add_argument("--scenario", metavar="FILE", help=f"scenario TOML (default {DEFAULT_SCENARIO.name})")
    parser.add_argument("--speed", type=float, metavar="X",
                        help="with --sitl: run the world X times faster than real time (lockstep, deterministic)")
    parser.add_argument("--out", metavar="DIR",
                        help="write gcs.tlog and events.jsonl here (default runs/console-NAME-TIME)")
    parser.add_argument("--paused", action="store_true", help="start with the scenario loop paused")
    parser.add_argument("--signing-key", type=Path, metavar="FILE",
                        help="MAVLink 2 signing with the passphrase in FILE (default: $VIL_SIGNING_KEY if set); "
                             "the aPad's unsigned frames are then refused")


def run_gcs(args: argparse.Namespace) -> int:
    from gcs.console.app import LiveConsole
    from gcs.console.runner import ConsoleConfig, ConsoleRunner

    path = Path(args.scenario) if args.scenario else DEFAULT_SCENARIO
    try:
        scenario = load_scenario(path)
        key = load_key(args.signing_key)
    except (ScenarioError, OSError, SigningKeyError) as exc:
        print(f"vil gcs: {exc}", file=sys.stderr)
        return 2
    if args.speed is not None and not args.sitl:
        print("vil gcs: --speed needs --sitl (a real aPad runs in real time)", file=sys.stderr)
        return 2
    out = Path(args.out) if args.out else Path("runs") / f"console-{scenario.name}-{time.strftime('%Y%m%dT%H%M%S')}"
    out.mkdir(parents=True, exist_ok=True)
    (out / "console.json").write_text(json.dumps({"scenario": scenario.name, "scenario_path": str(path.resolve())}))
    config = ConsoleConfig(
        scenario, connect=args.connect, sitl=args.sitl_link if args.sitl else None, speed=args.speed,
        out_dir=out, start_paused=args.paused, signing_key=key,
    )
    runner = ConsoleRunner(config)
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
    parser.add_argument("run", metavar="RUN_DIR_OR_TLOG", help="a run folder (gcs.tlog, events.jsonl) or a .tlog")
    parser.add_argument("--scenario", metavar="FILE", help="scenario TOML for the area and thresholds "
                                                           "(default: the one the run names)")
    parser.add_argument("--speed", type=float, default=8.0, help="playback speed, x real time (default 8)")
    parser.add_argument("--start", type=float, default=0.0, metavar="S", help="start at this mission time")
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
