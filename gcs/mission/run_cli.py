"""`vil run`: headless missions in lockstep, the paper's Table II by default.

    vil run                                    # Table II: pool12 cautious/greedy/none, bay24 greedy
    vil run missions/pool12.toml --strategy greedy --seed 3 --json out.json
    vil run pool12 --seeds 20                  # cautious, greedy, none on 20 freshly drawn fleets
    vil run --seeds 20                         # the same for pool12 and bay24: Table II's shape per seed
    vil run pool12 --loss 0.2 --latency 0.2 --duplicate 0.05   # aPad link over UDP through a fault proxy
    VIL_SIGNING_KEY=secret vil run pool12      # MAVLink 2 signing on the aPad link (or --signing-key FILE)
    vil run pool12 --resume                    # continue the run in its folder after a crash (kill -9)

Exit status: 0 every run finished with every aMussel where it should be; 2 bad input (one line
on stderr); 3 the runs finished but some aMussel is not where it should be (left at the surface,
off its position, or on a slot the GCS does not know): a red table says who is where.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, replace
from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from gcs.link.faultproxy import LinkFaults
from gcs.mission.headless import run_dir, run_mission
from gcs.mission.planner import COLLECT
from gcs.mission.results import (
    RunResult,
    misplaced_table,
    results_table,
    seed_stats,
    seed_stats_table,
    shape_table,
)
from gcs.mission.scenario import Scenario, ScenarioError, load_scenario, parse_duration_s
from gcs.mission.scenario_models import check_inputs
from gcs.mission.world import LinkOptions
from gcs.records.checkpoint import CHECKPOINT_NAME
from mavlink_dialect.signing import SigningKeyError, load_key

# The paper's Table II runs: (scenario, collection strategy).
TABLE_II = (("pool12", "cautious"), ("pool12", "greedy"), ("pool12", "none"), ("bay24", "greedy"))
# Over many seeds every scenario runs these, so the shape of Table II can be checked per seed.
SHAPE_STRATEGIES = ("cautious", "greedy", "none")
EXIT_MISPLACED = 3  # the runs finished, but some aMussel is not where it should be (the table says who)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "scenario", nargs="?", metavar="SCENARIO",
        help="scenario file (TOML) or a name in missions/ (pool12, bay24); none: the Table II reproduction",
    )
    parser.add_argument("--strategy", type=_strategies, metavar="NAME[,NAME...]",
                        help=f"collection strategy or a comma list of them ({', '.join(COLLECT)}); "
                             "default: the scenario's")
    parser.add_argument("--seed", type=int, help="seed of the run's random draws (default: the scenario's)")
    parser.add_argument("--seeds", type=int, metavar="N",
                        help="run seeds 1..N, each on a fleet drawn from its seed; print mean and spread")
    parser.add_argument("--draw-fleet", action="store_true",
                        help="draw the fleet from the seed instead of the scenario's saved start configuration")
    parser.add_argument("--duration", type=_duration, help='mission time, e.g. 2400, "40m", "1h" (default: 40m)')
    parser.add_argument("--theta", type=_positive, help="aMussel time scale (default: the scenario's, 30)")
    parser.add_argument("--json", type=Path, metavar="FILE", help="write the result(s) as JSON")
    parser.add_argument("--out", type=Path, default=Path("runs"), metavar="DIR",
                        help="output folder; each run leaves DIR/SCENARIO-STRATEGY-seedN/ (default: runs)")
    faults = parser.add_argument_group("link faults and security (the aPad link over real UDP through a seeded proxy)")
    faults.add_argument("--loss", type=_fraction, default=0.0, metavar="FRAC", help="drop this fraction of datagrams")
    faults.add_argument("--latency", type=_non_negative, default=0.0, metavar="S",
                        help="one-way delay, mission seconds")
    faults.add_argument("--jitter", type=_non_negative, default=0.0, metavar="S",
                        help="extra delay uniform in [0, S]; reorders datagrams")
    faults.add_argument("--duplicate", type=_fraction, default=0.0, metavar="FRAC",
                        help="send this fraction of datagrams twice")
    faults.add_argument("--outage", type=_outage, action="append", default=[], metavar="START:END",
                        help="total link loss between these mission times (s); repeatable")
    faults.add_argument("--proxy", action="store_true", help="route through the proxy even with no faults")
    faults.add_argument("--signing-key", type=Path, metavar="FILE",
                        help="MAVLink 2 signing with the passphrase in FILE (default: $VIL_SIGNING_KEY if set)")
    parser.add_argument("--resume", action="store_true",
                        help="continue the mission from the checkpoint in its output folder (after a crash)")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="parallel runs (default: CPU count)")


def _strategies(text: str) -> list[str]:
    names = [n.strip() for n in text.split(",") if n.strip()]
    unknown = [n for n in names if n not in COLLECT]
    if unknown or not names:
        raise argparse.ArgumentTypeError(f"invalid choice: {text!r} (choose from {', '.join(COLLECT)})")
    return names


def _duration(text: str) -> float:
    try:
        return parse_duration_s(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _outage(text: str) -> tuple[float, float]:
    start, sep, end = text.partition(":")
    try:
        window = (float(start), float(end))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected START:END in mission seconds, got {text!r}") from None
    if not sep or not 0 <= window[0] < window[1]:
        raise argparse.ArgumentTypeError(f"expected START:END with 0 <= START < END, got {text!r}")
    return window


def _fraction(text: str) -> float:
    value = _non_negative(text)
    if value >= 1.0:
        raise argparse.ArgumentTypeError(f"must be a fraction below 1, got {text}")
    return value


def _number(text: str, allow_zero: bool) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if allow_zero and not value >= 0:
        raise argparse.ArgumentTypeError(f"must not be negative, got {text}")
    if not allow_zero and not value > 0:
        raise argparse.ArgumentTypeError(f"must be positive, got {text}")
    return value


def _non_negative(text: str) -> float:
    return _number(text, allow_zero=True)


def _positive(text: str) -> float:
    return _number(text, allow_zero=False)


@dataclass(frozen=True)
class Job:
    scenario: Scenario
    out_dir: Path
    options: LinkOptions | None = None
    resume: bool = False


def _link_options(args: argparse.Namespace) -> LinkOptions | None:
    key = load_key(args.signing_key)
    faults = LinkFaults(args.loss, args.latency, args.jitter, args.duplicate, seed=args.seed or 0,
                        outages_s=tuple(args.outage))
    use_proxy = args.proxy or faults.any
    if not use_proxy and key is None:
        return None
    return LinkOptions(faults=faults if use_proxy else None, signing_key=key)


def _jobs(args: argparse.Namespace) -> list[Job]:
    strategies: list[str | None] = list(args.strategy) if args.strategy else [None]
    if args.scenario:
        if args.seeds and not args.strategy:
            strategies = list(SHAPE_STRATEGIES)
        pairs = [(args.scenario, s) for s in strategies]
    elif args.seeds:
        pairs = [(name, s) for name in ("pool12", "bay24") for s in (args.strategy or SHAPE_STRATEGIES)]
    else:
        pairs = [(name, s) for name, s in TABLE_II if not args.strategy or s in args.strategy]
    seeds: list[int | None] = list(range(1, args.seeds + 1)) if args.seeds else [args.seed]
    cache: dict[str, Scenario] = {}
    options = _link_options(args)
    for name, _ in pairs:
        if name not in cache:
            cache[name] = load_scenario(name)
            check_inputs(cache[name])
    jobs = []
    for name, strategy in pairs:
        base = cache.setdefault(name, load_scenario(name))
        for seed in seeds:
            s = base.with_overrides(strategy=strategy, seed=seed, duration_s=args.duration, theta=args.theta)
            if args.seeds or args.draw_fleet:
                s = replace(s, fleet=replace(s.fleet, start_config=None))
            jobs.append(Job(s, run_dir(args.out, s), options, args.resume))
    return jobs


def _run_job(job: Job) -> RunResult:
    return run_mission(job.scenario, job.out_dir, options=job.options, resume=job.resume)


def run(args: argparse.Namespace) -> int:
    console = Console()
    try:
        jobs = _jobs(args)
    except (ScenarioError, SigningKeyError) as exc:
        print(f"vil run: {exc}", file=sys.stderr)
        return 2
    if args.resume:
        missing = [j.out_dir for j in jobs if not (j.out_dir / CHECKPOINT_NAME).exists()]
        if missing:
            print(f"vil run: nothing to resume: no {CHECKPOINT_NAME} in {missing[0]}", file=sys.stderr)
            return 2
    if args.seeds is not None and args.seeds < 1:
        print("vil run: --seeds must be at least 1", file=sys.stderr)
        return 2
    results = _run_all(jobs, max(1, args.jobs), console)
    results.sort(key=lambda r: ([(j.scenario.name, j.scenario.mission.collect_strategy) for j in jobs]
                                .index((r.scenario, r.strategy)), r.seed))
    if args.seeds:
        title = f"{len(results)} runs, fleets drawn from seeds 1..{args.seeds}"
        console.print(seed_stats_table(seed_stats(results), title))
        console.print(shape_table(results))
    else:
        title = "Table II reproduction (lockstep SITL)" if not args.scenario else "Mission result"
        console.print(results_table(results, title))
    mission_s = sum(r.duration_s for r in results)
    run_s = sum(r.wall_s for r in results)
    out_dirs = sorted({str(Path(r.out_dir).parent) for r in results})
    console.print(f"{len(results)} run(s) of {mission_s / 60 / len(results):.0f} mission minutes, "
                  f"{run_s / len(results):.1f} s each (real-time factor {mission_s / run_s:.0f}); "
                  f"logs, .tlog and traces in {', '.join(out_dirs)}/")
    if args.json:
        payload = [r.to_json() for r in results]
        args.json.write_text(json.dumps(payload[0] if len(payload) == 1 else payload, indent=1) + "\n")
    misplaced = misplaced_table(results)
    if misplaced is not None:
        console.print(misplaced)
        return EXIT_MISPLACED
    return 0


def _run_all(jobs: list[Job], n_jobs: int, console: Console) -> list[RunResult]:
    columns = (TextColumn("[progress.description]{task.description}"), BarColumn(), MofNCompleteColumn(),
               TextColumn("mission s" if len(jobs) == 1 else "runs"), TimeElapsedColumn())
    with Progress(*columns, console=console, transient=True) as progress:
        if len(jobs) == 1:
            job = jobs[0]
            task = progress.add_task(f"{job.scenario.name} {job.scenario.mission.collect_strategy}",
                                     total=int(job.scenario.mission.duration_s))
            return [run_mission(job.scenario, job.out_dir, options=job.options, resume=job.resume,
                                progress=lambda t_s: progress.update(task, completed=int(t_s)))]
        task = progress.add_task(f"{len(jobs)} missions", total=len(jobs))
        results = []
        with ProcessPoolExecutor(max_workers=min(n_jobs, len(jobs))) as pool:
            for future in as_completed([pool.submit(_run_job, job) for job in jobs]):
                results.append(future.result())
                progress.advance(task)
        return results
