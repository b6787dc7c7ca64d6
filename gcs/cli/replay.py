"""`vil replay`: a recorded run on the console's screen, played back from its logs.

    vil replay runs/latest                           # the last run started (vil run, vil gcs or vil.run)
    vil replay runs/pool12-cautious-seed1-run1 --speed 32 --start 12min
    vil replay runs/latest/gcs.tlog --scenario missions/pool12.toml --paused

The run's GCS .tlog and events.jsonl drive the same map, tables and plots `vil gcs` shows; no aPad
is needed. The scenario (for the water area and the pool threshold) is the one the run names,
unless --scenario says otherwise. Keys: space plays and pauses, + and - change the speed, the
arrows seek 10 s (shift or PgUp/PgDn 60 s, Home and End to either end), ? explains, q or ctrl+c
quits. What cannot be replayed (no such folder, no .tlog, an empty log) is one line and exit 2.
"""

from __future__ import annotations

import argparse
import sys

from gcs.cli import flags
from gcs.cli.console import SPEED_RANGE
from gcs.scenario.reader import ScenarioError
from missiontime import mm_ss


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("run", metavar="RUN_DIR_OR_TLOG",
                        help="a run folder (gcs.tlog, events.jsonl; runs/latest: the last run) or a .tlog")
    parser.add_argument("--scenario", metavar="FILE", help="scenario TOML for the area and thresholds "
                                                           "(default: the one the run names)")
    parser.add_argument("--speed", type=flags.number_in(*SPEED_RANGE), default=8.0,
                        help=f"playback speed, x real time ({SPEED_RANGE[0]:g} to {SPEED_RANGE[1]:g}, default 8)")
    parser.add_argument("--start", type=flags.mission_time, default=0.0, metavar="T",
                        help="start at this mission time, with its unit: 90s, 12min")
    parser.add_argument("--paused", action="store_true", help="start paused")


def run(args: argparse.Namespace) -> int:
    from gcs.console.app import ReplayConsole
    from gcs.records.playback import ReplayError, load_replay

    try:
        replay = load_replay(args.run, args.scenario)
    except (ReplayError, ScenarioError, OSError) as exc:
        print(f"vil replay: {exc}", file=sys.stderr)
        return 2
    if args.start > replay.end_s:
        print(f"vil replay: --start {mm_ss(args.start)} is past the end of {args.run} ({mm_ss(replay.end_s)})",
              file=sys.stderr)
        return 2
    ReplayConsole(replay, start_s=args.start, playing=not args.paused, speed=args.speed).run()
    return 0
