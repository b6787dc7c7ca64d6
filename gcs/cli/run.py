"""`vil run`: headless missions, in lockstep (the reference) or on the event platform; Table II by default.

    vil run                                    # Table II: pool12 cautious/greedy/none, bay24 greedy
    vil run missions/pool12.toml --strategy greedy --seed 3 --json out.json
    vil run pool12 --seeds 20                  # cautious, greedy, none on 20 freshly drawn fleets
    vil run --seeds 20                         # the same for pool12 and bay24: Table II's shape per seed
    vil run pool12 --loss 0.2 --latency 200ms --duplicate 0.05 # aPad link over UDP through a fault proxy
    VIL_SIGNING_KEY=secret vil run pool12      # MAVLink 2 signing on the aPad link (or --signing-key FILE)
    vil run pool12 --resume                    # continue the run in its folder after a crash (kill -9)
    vil run bay120-sleep --duration 24h --platform event   # discrete events over an ideal link: seconds
    vil run pool12 --strategy mine.py:slack_first,cautious   # a strategy of your own beside a shipped one

Every run gets a new folder, OUT/SCENARIO-STRATEGY-seedN-runK (K one past the highest there), and
OUT/latest points at the last one started; `--resume` continues the newest folder of the same
scenario, strategy and seed that holds a checkpoint, and writes each event once.

Exit status: 0 every run finished with every aMussel where it should be (aMussels that ran flat on
their positions are a result, not a fault: the summary says how many and when); 2 bad input (one line
on stderr); 3 the runs finished but some aMussel is not where it should be (left at the surface,
off its position, or on a slot the GCS does not know): a red table says who is where; 130
interrupted (Ctrl-C): one line says where the checkpoint is and the exact command that resumes it.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import sys
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import replace
from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from gcs.cli import flags
from gcs.cli.tables import (
    apads_table,
    days_table,
    happened_lines,
    misplaced_table,
    output_console,
    results_table,
    seed_stats_table,
    shape_table,
    time_table,
)
from gcs.mission import checkpoint
from gcs.mission.checkpoint import CheckpointError
from gcs.mission.platform import DEFAULT_PLATFORM, PLATFORM_HELP, Platform, platform_title
from gcs.mission.start import MAX_DELAY_S, PreparedRun, RunOptions, prepare_runs, run_prepared
from gcs.records.run_folder import RunFolder
from gcs.results.run_result import RunResult, seed_stats
from gcs.scenario.reader import SEED_MAX, THETA_RANGE, Scenario, ScenarioError, load_scenario, shipped_scenarios
from gcs.strategies import COLLECT, StrategyError, load_strategy
from mavlink_dialect.signing import SigningKeyError, load_key
from missiontime.durations import hms

# The paper's Table II runs: (scenario, collection strategy).
TABLE_II = (("pool12", "cautious"), ("pool12", "greedy"), ("pool12", "none"), ("bay24", "greedy"))
# Over many seeds every scenario runs these, so the shape of Table II can be checked per seed.
SHAPE_STRATEGIES = ("cautious", "greedy", "none")
EXIT_MISPLACED = 3  # the runs finished, but some aMussel is not where it should be (the table says who)
EXIT_INTERRUPTED = 130  # Ctrl-C, as a shell reports SIGINT
MAX_SEEDS = 1000
MAX_JOBS = 256


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "scenario", nargs="?", metavar="SCENARIO",
        help=f"scenario file (TOML) or a name in missions/ ({', '.join(shipped_scenarios())}); none: Table II",
    )
    parser.add_argument("--strategy", type=_strategies, metavar="NAME[,NAME...]",
                        help=f"collection strategy or a comma list of them: shipped ({', '.join(COLLECT)}), "
                             "FILE.py:FUNCTION, MODULE:FUNCTION or an installed vil.strategies entry point "
                             "(docs/strategies.md); default: the scenario's")
    seeds = parser.add_mutually_exclusive_group()  # both: which would the runs use? refused in one line
    seeds.add_argument("--seed", type=flags.integer_in(0, SEED_MAX),
                        help="seed of the run's random draws (default: the scenario's); with a saved start "
                             "configuration the fleet stays the saved one: the seed then draws the drift only")
    seeds.add_argument("--seeds", type=flags.integer_in(1, MAX_SEEDS), metavar="N",
                        help=f"run seeds 1..N (N <= {MAX_SEEDS}), each on a fleet drawn from its seed; "
                             "print mean and spread")
    parser.add_argument("--draw-fleet", action="store_true",
                        help="draw the fleet from the seed instead of the scenario's saved start configuration")
    parser.add_argument("--duration", type=flags.duration,
                        help="mission time with its unit, up to 90 days: 90s, 40min, 1h, 7d (default: the scenario's)")
    parser.add_argument("--theta", type=flags.number_in(*THETA_RANGE),
                        help=f"aMussel time scale in [{THETA_RANGE[0]:g}, {THETA_RANGE[1]:g}] "
                             "(default: the scenario's, 30)")
    parser.add_argument("--platform", type=flags.platform, default=DEFAULT_PLATFORM, metavar="NAME",
                        help=PLATFORM_HELP)
    parser.add_argument("--json", type=flags.writable_file, metavar="FILE", help="write the result(s) as JSON")
    parser.add_argument("--out", type=flags.writable_dir, default="runs", metavar="DIR",
                        help="output folder; each run leaves a new DIR/SCENARIO-STRATEGY-seedN-runK/ and "
                             "DIR/latest points at the last one (default: runs)")
    faults = parser.add_argument_group("link faults and security (the aPad link over real UDP through a seeded proxy)")
    faults.add_argument("--loss", type=flags.fraction, default=0.0, metavar="FRAC",
                        help="drop this fraction of datagrams")
    faults.add_argument("--latency", type=flags.duration_up_to(MAX_DELAY_S), default=0.0, metavar="T",
                        help=f"one-way delay in mission time, with its unit: 200ms, 0.2s (at most {MAX_DELAY_S:g}s)")
    faults.add_argument("--jitter", type=flags.duration_up_to(MAX_DELAY_S), default=0.0, metavar="T",
                        help="extra delay uniform in [0, T], with its unit; reorders datagrams")
    faults.add_argument("--duplicate", type=flags.fraction, default=0.0, metavar="FRAC",
                        help="send this fraction of datagrams twice")
    faults.add_argument("--outage", type=flags.window, action="append", default=[], metavar="START:END",
                        help="total link loss between these mission times, with units: 92s:112s; repeatable")
    faults.add_argument("--fail-apad", type=flags.apad_at, action="append", default=[], metavar="SYSID:T",
                        help="that aPad goes silent for good at mission time T, with its unit (3:10min): the "
                             "swarm re-shares its aMussels; repeatable")
    faults.add_argument("--proxy", action="store_true", help="route through the proxy even with no faults")
    faults.add_argument("--signing-key", type=Path, metavar="FILE",
                        help="MAVLink 2 signing with the passphrase in FILE (default: $VIL_SIGNING_KEY if set)")
    parser.add_argument("--resume", action="store_true",
                        help="after a crash: continue the newest DIR/SCENARIO-STRATEGY-seedN-runK/ holding a "
                             "checkpoint, in that folder, each event written once; give the flags the run was "
                             "started with. The mission is replayed to its checkpoint (its logs muted), so the "
                             "results are those of a run never interrupted")
    parser.add_argument("--jobs", type=flags.integer_in(1, MAX_JOBS), default=os.cpu_count() or 1,
                        help="parallel runs (default: CPU count)")


def _strategies(text: str) -> list[str]:
    """Each strategy named, loaded if it comes from a file, module or package (gcs.strategies.plugins)."""
    specs = [n.strip() for n in text.split(",") if n.strip()]
    if not specs:
        raise argparse.ArgumentTypeError(f"no strategy in {text!r} (shipped: {', '.join(COLLECT)})")
    try:
        names = [load_strategy(spec) for spec in specs]
    except StrategyError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return list(dict.fromkeys(names))  # a name twice would run (or resume) the same folder twice


def _requests(args: argparse.Namespace) -> list[tuple[Scenario, RunOptions]]:
    """Every run the flags ask for: each scenario loaded once, with each strategy and seed."""
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
    common = RunOptions(
        duration_s=args.duration, theta=args.theta, draw_fleet=bool(args.seeds or args.draw_fleet),
        loss_frac=args.loss, latency_s=args.latency, jitter_s=args.jitter, duplicate_frac=args.duplicate,
        outages_s=tuple(args.outage), fail_apads=tuple(args.fail_apad), proxy=args.proxy,
        signing_key=load_key(args.signing_key), resume=args.resume, out=args.out, platform=args.platform,
    )
    scenarios: dict[str, Scenario] = {}
    requests = []
    for name, strategy in pairs:
        if name not in scenarios:
            scenarios[name] = load_scenario(name)
        for seed in seeds:
            requests.append((scenarios[name], replace(common, strategy=strategy, seed=seed)))
    return requests


def _command_line(args: argparse.Namespace) -> str:
    """The command as given (`vil run ...`) without --resume, quoted for a shell: what a new run's
    folder keeps, and what resumes it with --resume added."""
    return shlex.join(["vil", *(a for a in getattr(args, "argv", ["run"]) if a != "--resume")])


def _interrupted(jobs: list[PreparedRun]) -> str:
    """One line for a Ctrl-C: what was kept, and the exact command to go on."""
    kept = [f for f in (RunFolder(j.out_dir) for j in jobs) if f.checkpoint.exists()]
    if not kept:
        return "interrupted before the first checkpoint: nothing to resume (run the command again)"
    try:
        at = ", ".join(hms(checkpoint.load(f.checkpoint).time_us / 1e6) for f in kept)
    except CheckpointError:
        at = "?"
    how = kept[0].resume_command() or "the same command with --resume"
    where = str(kept[0].path) if len(kept) == 1 else f"{len(kept)} run folders under {kept[0].path.parent}"
    return f"interrupted; checkpoint kept in {where} (mission time {at}); resume with: {how}"


def _run_job(job: PreparedRun) -> RunResult:
    """One run in a pool worker. A Ctrl-C (the whole process group gets it) ends the worker, not just
    this run: a worker that only lost its run would take the next queued one, and the pool would
    wait for it."""
    try:
        return run_prepared(job)
    except KeyboardInterrupt:  # the run's logs are closed and its checkpoint kept by now
        os._exit(EXIT_INTERRUPTED)


def run(args: argparse.Namespace) -> int:
    console = output_console()
    try:
        jobs = prepare_runs(_requests(args), _command_line(args), _say)
    except (ScenarioError, SigningKeyError, CheckpointError) as exc:
        print(f"vil run: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # the output folder went away or filled up since the flag was checked
        print(f"vil run: --out {args.out}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    try:
        results = _run_all(jobs, args.jobs, console)
    except TimeoutError as exc:  # e.g. an --outage over the start: the aPad was never heard
        print(f"vil run: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:  # Ctrl-C: an ordinary way to stop; the checkpoint says where to go on
        print(f"vil run: {_interrupted(jobs)}", file=sys.stderr)
        return EXIT_INTERRUPTED
    results.sort(key=lambda r: ([(j.scenario.name, j.scenario.mission.collect_strategy) for j in jobs]
                                .index((r.scenario, r.strategy)), r.seed))
    if args.json:  # before the tables: a reader that stops reading them does not lose it
        payload = [r.to_json() for r in results]
        args.json.write_text(json.dumps(payload[0] if len(payload) == 1 else payload, indent=1) + "\n")
    _print_results(results, args, console)  # a reader that stops reading is not an error (`output_console`)
    return EXIT_MISPLACED if any(r.misplaced for r in results) else 0


def _print_results(results: list[RunResult], args: argparse.Namespace, console: Console) -> None:
    """The tables, what happened besides, the summary line, and who is not where they should be."""
    if args.seeds:
        title = f"{len(results)} runs, fleets drawn from seeds 1..{args.seeds}"
        console.print(seed_stats_table(seed_stats(results), title))
        console.print(shape_table(results))
    else:
        title = f"Table II reproduction ({platform_title(args.platform)})" if not args.scenario else \
            f"Mission result ({platform_title(args.platform)})"
        console.print(results_table(results, title))
        for table in (apads_table(results), time_table(results),
                      days_table([(f"{r.scenario} {r.strategy} s{r.seed}", r.days) for r in results])):
            if table is not None:
                console.print(table)
    for line in happened_lines(results):  # faults, holds, link losses, lost aPads: what the figures do not say
        console.print(line, highlight=False)
    mission_s = sum(r.duration_s for r in results)
    run_s = sum(r.wall_s for r in results)
    each_s = mission_s / len(results)
    length = f"{each_s / 60:.0f} mission minutes" if each_s < 3600 else f"{hms(each_s)} mission time"
    logs = "logs, .tlog and traces" if args.platform is Platform.LOCKSTEP else \
        "logs and traces (no .tlog: the event platform's link carries no bytes)"
    console.print(f"{len(results)} run(s) of {length} on the {args.platform} platform, "
                  f"{run_s / len(results):.1f} s each (real-time factor {mission_s / run_s:.0f}); "
                  f"{logs} in {_folders(results)}")
    misplaced = misplaced_table(results)
    if misplaced is not None:
        console.print(misplaced)


def _folders(results: list[RunResult]) -> str:
    """The run folders, by name: all of them when they are few, else where they are and the first."""
    folders = [f"{r.out_dir}/" for r in results]
    if len(folders) <= 4:
        return ", ".join(folders)
    parents = sorted({str(Path(r.out_dir).parent) for r in results})
    return f"{len(folders)} folders in {', '.join(parents)}/ ({Path(folders[0]).name}, ...)"


def _say(line: str) -> None:
    print(f"vil run: {line}", file=sys.stderr)


def _run_all(jobs: list[PreparedRun], n_jobs: int, console: Console) -> list[RunResult]:
    kept = [j.finished for j in jobs if j.finished is not None]
    to_run = [j for j in jobs if j.finished is None]
    return kept + (_run_jobs(to_run, n_jobs, console) if to_run else [])


def _run_jobs(jobs: list[PreparedRun], n_jobs: int, console: Console) -> list[RunResult]:
    columns = (TextColumn("[progress.description]{task.description}"), BarColumn(), MofNCompleteColumn(),
               TextColumn("mission s" if len(jobs) == 1 else "runs"), TimeElapsedColumn())
    with Progress(*columns, console=console, transient=True) as progress:
        if len(jobs) == 1:
            job = jobs[0]
            task = progress.add_task(f"{job.scenario.name} {job.scenario.mission.collect_strategy}",
                                     total=int(job.scenario.mission.duration_s))
            return [run_prepared(job, progress=lambda t_s: progress.update(task, completed=int(t_s)))]
        task = progress.add_task(f"{len(jobs)} missions", total=len(jobs))
        results = []
        pool = ProcessPoolExecutor(max_workers=min(n_jobs, len(jobs)))
        try:
            for future in as_completed([pool.submit(_run_job, job) for job in jobs]):
                results.append(future.result())
                progress.advance(task)
        finally:  # a Ctrl-C reached the workers too: what has not started never will
            pool.shutdown(wait=True, cancel_futures=True)
        return results
