"""The event platform held to lockstep's answers, side by side in one sitting (issue 37; docs/platforms.md).

Three parts, each a table (all by default, or one with --part):

  agreement  every shipped scenario with every shipped strategy, --seeds fleets drawn from the seeds,
             40 minutes on both platforms: the mean of avg and min uptime, cost and dockings on each,
             their differences against the bounds below, and the seeds whose first collection plan
             differs (each aPad's first route of aMussel ids, by aPad: several may plan at one instant)
  long       --long-seeds seeds of 24 h for pool12, bay120 and bay120-sleep: mean uptime, how many
             aMussels ran flat (the verdict: none, or some) and wall time on each
  speed      each platform's wall time and the ratio, one run at a time in a fresh process: pool12 40
             min, bay120-sleep 24 h, one aPad with 48 hourly-wake aMussels for 24 h (bay-capacity), and on
             the event platform alone a simulated year of bay120-sleep (292 h of mission time at theta 30)
             with its peak RSS against its 24 h's

The bounds (issue 37): avg uptime within 1.0 percentage point, min uptime within 2.0, cost within 5 %;
24-h mean uptime within 2.0 and the same verdict; the first plan the same on at least 19 of 20 seeds.
A row outside them is marked MISS. Asserts nothing (a benchmark); the machine's speed swings by a third
within the hour, so the speed rows run one at a time, interleaved, each the best of --repeat.

    .venv/bin/python bench/platforms.py [--part agreement|long|speed] [--seeds 20] [--long-seeds 5]
        [--scenarios pool12,bay24] [--strategies cautious,greedy] [--leave-out stress240:rolling] [--jobs 2]
        [--repeat 1]
        [--speed-cases pool12,sleep-day,capacity,year]
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import resource
import statistics
import tempfile
import time
from collections.abc import Iterable
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass

from rich.console import Console
from rich.table import Table

SHORT = "40min"
DAY = "24h"
YEAR_H = 292  # a simulated year at theta 30: 365 x 24 h / 30
LONG_SCENARIOS = ("pool12", "bay120", "bay120-sleep")
PLATFORMS = ("lockstep", "event")
AVG_PP, MIN_PP, COST_FRAC, DAY_PP, PLAN_SHARE = 1.0, 2.0, 0.05, 2.0, 19 / 20


@dataclass(frozen=True)
class Job:
    scenario: str
    strategy: str | None
    seed: int
    duration: str
    platform: str
    fields: tuple[tuple[str, object], ...] = ()  # scenario fields changed (bay-capacity's fleet)


@dataclass(frozen=True)
class Outcome:
    job: Job
    avg: float
    min: float
    cost: float
    dockings: int
    depleted: int
    home_charges: int  # the aPads' charges at their home chargers, summed
    first_plan: tuple[tuple[int, tuple[int, ...]], ...]  # each aPad's first collection plan, by aPad
    wall_s: float
    rss_mb: float


def run_job(job: Job) -> Outcome:
    """One mission in this process, its folder in a temporary place (the events give the first plan)."""
    import vil  # here: a fresh process imports it once

    with tempfile.TemporaryDirectory() as out:
        base = vil.scenario(job.scenario, dict(job.fields)) if job.fields else job.scenario
        start = time.perf_counter()
        r = vil.run(base, strategy=job.strategy, seed=job.seed, draw_fleet=True, duration=job.duration,
                    platform=job.platform, out=out)
        wall = time.perf_counter() - start
        raw = r.raw
        plans: dict[int, tuple[int, ...]] = {}  # several aPads planning at one instant log in either order
        dockings = 0
        with (r.folder / "events.jsonl").open() as events:
            for line in events:
                e = json.loads(line)
                if e["event"] == "plan_collection":
                    plans.setdefault(e.get("apad", 0), tuple(e.get("route", ())))
                dockings += e["event"] == "docked"
    depleted = sum(1 for m in raw.mussels if m.first_depleted_s is not None)
    home_charges = sum(int(a.get("home_charges", 0)) for a in raw.apads)
    rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return Outcome(job, raw.uptime["avg"], raw.uptime["min"], raw.cost_m, dockings, depleted, home_charges,
                   tuple(sorted(plans.items())), wall, rss_mb)


def pool_of(n_jobs: int, max_tasks_per_child: int | None = None) -> ProcessPoolExecutor:
    """Worker processes that import `vil` afresh (spawned, not forked from a parent that ran missions)."""
    return ProcessPoolExecutor(n_jobs, mp_context=multiprocessing.get_context("spawn"),
                               max_tasks_per_child=max_tasks_per_child)


def run_all(jobs: list[Job], n_jobs: int) -> list[Outcome]:
    with pool_of(n_jobs) as pool:
        return list(pool.map(run_job, jobs))


def run_fresh(job: Job) -> Outcome:
    """In a process of its own (its peak RSS is its own)."""
    with pool_of(1, max_tasks_per_child=1) as pool:
        return pool.submit(run_job, job).result()


def shipped() -> tuple[list[str], list[str]]:
    from gcs.scenario.reader import shipped_scenarios
    from gcs.strategies import shipped_names

    return shipped_scenarios(), list(shipped_names())


def mark(ok: bool) -> str:
    return "" if ok else " [red]MISS[/]"


def agreement(console: Console, scenarios: list[str], strategies: list[str], seeds: int, n_jobs: int,
              leave_out: frozenset[tuple[str, str]] = frozenset()) -> None:
    """Each row is printed as its last mission ends (a sitting cut short keeps what it ran), then the table."""
    pairs = [(sc, st) for sc in scenarios for st in strategies if (sc, st) not in leave_out]
    jobs = [Job(sc, st, seed, SHORT, p) for sc, st in pairs for seed in range(1, seeds + 1) for p in PLATFORMS]
    left: dict[tuple[str, str], int] = {pair: seeds * len(PLATFORMS) for pair in pairs}
    done: dict[tuple[str, str], list[Outcome]] = {pair: [] for pair in pairs}
    rows: dict[tuple[str, str], list[str]] = {}
    start = time.perf_counter()
    with pool_of(n_jobs) as pool:
        for future in as_completed([pool.submit(run_job, job) for job in jobs]):
            outcome = future.result()
            pair = (outcome.job.scenario, outcome.job.strategy or "")
            done[pair].append(outcome)
            left[pair] -= 1
            if not left[pair]:
                rows[pair] = _agreement_row(done[pair])
                console.print(f"[{time.perf_counter() - start:.0f} s] {pair[0]} {pair[1]}: " + " | ".join(rows[pair]))
    table = Table(title=f"Agreement: {seeds} seeds of {SHORT} per scenario and strategy, fleets drawn "
                        f"({time.perf_counter() - start:.0f} s on {n_jobs} processes)")
    for column in ("scenario", "strategy", "avg % L / E (diff)", "min % L / E (diff)", "cost m L / E (diff)",
                   "dockings L / E", "plans same", "wall s L / E"):
        table.add_column(column, justify="left" if column in ("scenario", "strategy") else "right")
    for pair in pairs:
        table.add_row(*pair, *rows[pair])
    console.print(table)
    if leave_out:
        console.print("left out: " + ", ".join(f"{sc} {st}" for sc, st in sorted(leave_out)))


def _agreement_row(outcomes: list[Outcome]) -> list[str]:
    """One scenario and strategy: each figure on both platforms (seed by seed in seed order), marked where it misses."""
    lo, ev = ([o for o in sorted(outcomes, key=lambda o: o.job.seed) if o.job.platform == p] for p in PLATFORMS)
    avg = [statistics.fmean(o.avg for o in r) for r in (lo, ev)]
    low = [statistics.fmean(o.min for o in r) for r in (lo, ev)]
    cost = [statistics.fmean(o.cost for o in r) for r in (lo, ev)]
    docks = [statistics.fmean(o.dockings for o in r) for r in (lo, ev)]
    same = sum(a.first_plan == b.first_plan for a, b in zip(lo, ev, strict=True))
    cost_ok = abs(cost[1] - cost[0]) <= COST_FRAC * max(cost[0], 1e-9) or cost[0] == cost[1]
    return [
        f"{avg[0]:.2f} / {avg[1]:.2f} ({avg[1] - avg[0]:+.2f}){mark(abs(avg[1] - avg[0]) <= AVG_PP)}",
        f"{low[0]:.2f} / {low[1]:.2f} ({low[1] - low[0]:+.2f}){mark(abs(low[1] - low[0]) <= MIN_PP)}",
        f"{cost[0]:.1f} / {cost[1]:.1f} ({_pct(cost)}){mark(cost_ok)}",
        f"{docks[0]:.1f} / {docks[1]:.1f}",
        f"{same}/{len(lo)}{mark(same >= PLAN_SHARE * len(lo))}",
        f"{sum(o.wall_s for o in lo):.1f} / {sum(o.wall_s for o in ev):.1f}",
    ]


def _pct(pair: list[float]) -> str:
    return f"{100 * (pair[1] - pair[0]) / pair[0]:+.1f} %" if pair[0] else "n/a"


def long_runs(console: Console, seeds: int, n_jobs: int) -> None:
    jobs = [Job(sc, None, seed, DAY, p) for sc in LONG_SCENARIOS for seed in range(1, seeds + 1) for p in PLATFORMS]
    done = run_all(jobs, n_jobs)
    table = Table(title=f"{seeds} seeds of {DAY} (the scenarios' own strategies)")
    for column in ("scenario", "mean avg % L / E (diff)", "avg % range L / E", "depleted L / E (verdict)",
                   "home charges L / E", "wall s L / E", "ratio"):
        table.add_column(column, justify="left" if column == "scenario" else "right")
    for sc in LONG_SCENARIOS:
        lo = [o for o in done if o.job.scenario == sc and o.job.platform == "lockstep"]
        ev = [o for o in done if o.job.scenario == sc and o.job.platform == "event"]
        avg = [statistics.fmean(o.avg for o in r) for r in (lo, ev)]
        dep = [sum(o.depleted for o in r) for r in (lo, ev)]
        wall = [sum(o.wall_s for o in r) for r in (lo, ev)]
        verdict = (dep[0] == 0) == (dep[1] == 0)
        spans = " / ".join(f"{min(o.avg for o in r):.2f}-{max(o.avg for o in r):.2f}" for r in (lo, ev))
        charges = " / ".join(str(sum(o.home_charges for o in r)) for r in (lo, ev))
        table.add_row(sc, f"{avg[0]:.2f} / {avg[1]:.2f} ({avg[1] - avg[0]:+.2f}){mark(abs(avg[1] - avg[0]) <= DAY_PP)}",
                      spans, f"{dep[0]} / {dep[1]}{mark(verdict)}", charges, f"{wall[0]:.1f} / {wall[1]:.1f}",
                      f"{wall[0] / wall[1]:.0f}x" if wall[1] else "")
    console.print(table)


CAPACITY = (("fleet.count", 48), ("fleet.profile", "hourly_wake"))


SPEED_CASES = {
    "pool12": ("pool12 40 min", Job("pool12", None, 1, SHORT, "")),
    "sleep-day": ("bay120-sleep 24 h", Job("bay120-sleep", None, 1, DAY, "")),
    "capacity": ("1 aPad, 48 hourly-wake, 24 h", Job("bay-capacity", None, 1, DAY, "", CAPACITY)),
}


def speed(console: Console, repeat: int, cases: list[str]) -> None:
    table = Table(title=f"Speed: one run at a time, each in a fresh process, best of {repeat}")
    for column in ("mission", "lockstep s", "event s", "ratio", "event RTF", "event peak RSS MB"):
        table.add_column(column, justify="left" if column == "mission" else "right")
    for label, base in (SPEED_CASES[c] for c in cases if c in SPEED_CASES):
        best: dict[str, Outcome] = {}
        for _ in range(repeat):
            for p in PLATFORMS:  # interleaved: a slow minute costs both alike
                o = run_fresh(Job(base.scenario, base.strategy, base.seed, base.duration, p, base.fields))
                if p not in best or o.wall_s < best[p].wall_s:
                    best[p] = o
        lo, ev = best["lockstep"], best["event"]
        mission_s = _seconds(base.duration)
        table.add_row(label, f"{lo.wall_s:.2f}", f"{ev.wall_s:.3f}", f"{lo.wall_s / ev.wall_s:.1f}x",
                      f"{mission_s / ev.wall_s:,.0f}", f"{ev.rss_mb:.0f}")
    if "year" in cases:
        day = run_fresh(Job("bay120-sleep", None, 1, DAY, "event"))
        year = run_fresh(Job("bay120-sleep", None, 1, f"{YEAR_H}h", "event"))
        table.add_row(f"bay120-sleep {YEAR_H} h (a simulated year)", "", f"{year.wall_s:.1f}", "",
                      f"{_seconds(f'{YEAR_H}h') / year.wall_s:,.0f}",
                      f"{year.rss_mb:.0f} ({year.rss_mb / day.rss_mb:.2f}x its 24 h's)")
    console.print(table)


def _seconds(text: str) -> float:
    from missiontime.durations import parse_duration_s

    return parse_duration_s(text, 10 * 365 * 86400.0)


def _names(text: str | None, default: Iterable[str]) -> list[str]:
    return [n.strip() for n in text.split(",") if n.strip()] if text else list(default)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--part", choices=("agreement", "long", "speed"), action="append")
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--long-seeds", type=int, default=5)
    parser.add_argument("--scenarios", help="comma list (default: every shipped scenario)")
    parser.add_argument("--strategies", help="comma list (default: every shipped strategy)")
    parser.add_argument("--leave-out", help="comma list of scenario:strategy pairs the agreement part skips "
                                            "(named under its table)")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--speed-cases", default=",".join([*SPEED_CASES, "year"]),
                        help=f"comma list of {', '.join([*SPEED_CASES, 'year'])} (default: all)")
    args = parser.parse_args()
    parts = args.part or ["agreement", "long", "speed"]
    console = Console(width=200)
    scenarios, strategies = shipped()
    if "agreement" in parts:
        leave_out = frozenset((pair.partition(":")[0], pair.partition(":")[2]) for pair in _names(args.leave_out, ()))
        agreement(console, _names(args.scenarios, scenarios), _names(args.strategies, strategies), args.seeds,
                  args.jobs, leave_out)
    if "long" in parts:
        long_runs(console, args.long_seeds, args.jobs)
    if "speed" in parts:
        speed(console, args.repeat, _names(args.speed_cases, ()))


if __name__ == "__main__":
    main()
