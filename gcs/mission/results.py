"""Run results: the paper's Table II indices, as JSON and as rich tables beside the paper's figures."""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from rich import box
from rich.console import Console
from rich.table import Table

from missiontime import mm_ss

PIPED_WIDTH = 1000  # written to a file or a pipe, output is as wide as it needs, never cut at 80 columns


def output_console() -> Console:
    """Where the tables go: the terminal's width on a terminal (or $COLUMNS if set); a file or a
    pipe gets every column and every line whole (rich would cut them at 80 columns)."""
    piped = not sys.stdout.isatty() and "COLUMNS" not in os.environ
    return Console(width=PIPED_WIDTH) if piped else Console()


# The paper's Table II (40 min, theta = 30): avg %, max %, min %, cost m, active.
PAPER_TABLE_II: dict[tuple[str, str], tuple[float, float, float, float, float]] = {
    ("pool12", "cautious"): (74.37, 87.38, 59.88, 307.1746, 8.9243),
    ("pool12", "greedy"): (72.27, 87.16, 42.84, 247.8026, 8.9495),
    ("bay24", "greedy"): (71.98, 90.31, 31.18, 186.4318, 16.2368),
    ("pool12", "none"): (67.36, 79.56, 56.64, 0.0, 8.0837),
}


@dataclass(frozen=True)
class MusselResult:
    id: int
    start_battery: float
    uptime_pct: float
    dockings: list[dict[str, Any]] = field(default_factory=list)  # each {"t_s", "apad"} that docked it
    state_s: dict[str, float] = field(default_factory=dict)  # seconds in each state; they sum to the mission time
    first_depleted_s: float | None = None  # mission time it first depleted; None: never
    # Its behaviour profile at the end (mussel_sim.behaviour; a sleep order's shows as "PROFILE+order:..."),
    # and the wakes of its schedule: ACTIVE on the seabed at the time / all (0 and 0: always on).
    profile: str = "always_on"
    samples_taken: int = 0
    samples_scheduled: int = 0


@dataclass(frozen=True)
class RunResult:
    scenario: str
    strategy: str
    seed: int
    theta: float
    duration_s: float
    uptime: dict[str, float]  # avg, max, min in percent (eq. 3)
    cost_m: float  # the paper's movement cost: aPad-to-setpoint distances over all Go To commands
    active_avg: float  # mean number of active aMussels per step
    wall_s: float
    mussels: list[MusselResult]
    travelled_m: float = 0.0  # what the aPad's odometer says it really moved
    cycles: int = 0  # completed collect-charge-redeploy cycles
    end_reason: str = ""
    out_dir: str = ""
    messages: dict[str, int] = field(default_factory=dict)  # MAVLink counters of the run
    whereabouts: list[dict[str, Any]] = field(default_factory=list)  # every aMussel at the end (gcs.mission.accounting)
    # What happened that a user would want to know: faults injected, failsafe holds, link losses,
    # aPads lost, re-shares, steps given up (`gcs.mission.outcome.happenings`)
    happened: dict[str, Any] = field(default_factory=dict)
    # One row per aPad (gcs.mission.outcome.apad_rows), with its travelling, docking and holding shares
    # of the mission time (gcs.mission.time_accounting).
    apads: list[dict[str, Any]] = field(default_factory=list)
    # Per simulated day (86,400 s / theta of mission time; `gcs.mission.days.day_rows`), every day
    sim_day_s: float = 0.0
    days: list[dict[str, Any]] = field(default_factory=list)
    # An acoustic scenario's channel: the TDMA frame and slot table, reports sent and heard, call-ups,
    # drops by reason, and belief against truth (`gcs.acoustic.network.AcousticNetwork.summary`); {}: WiFi only
    acoustic: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> RunResult:
        """The result `to_json` wrote (a run's result.json read back)."""
        return cls(**{**data, "mussels": [MusselResult(**m) for m in data["mussels"]]})

    @property
    def misplaced(self) -> list[dict[str, Any]]:
        """The aMussels that did not end where they should: left at the surface, off their
        position, or docked where the GCS does not know (gcs.mission.accounting)."""
        return [w for w in self.whereabouts if w["where"] == "lost"]


def misplaced_table(results: list[RunResult]) -> Table | None:
    """Who is where, for every aMussel of every run that did not end where it should; None if all did."""
    rows = [(r, w) for r in results for w in r.misplaced]
    if not rows:
        return None
    table = Table(title="[bold red]aMussels not where they should be[/]", box=box.SIMPLE_HEAD, title_justify="left")
    for name in ("run", "aMussel", "where"):
        table.add_column(name, style="red")
    for r, w in rows:
        table.add_row(f"{r.scenario} {r.strategy} s{r.seed}", str(w["id"]), str(w["detail"]))
    return table


def happened_lines(results: list[RunResult]) -> list[str]:
    """One line per run that had something besides the figures to say (`RunResult.happened`)."""
    lines = []
    for r in results:
        h = r.happened
        parts = []
        if "faults" in h:
            f = h["faults"]
            said = [f"loss {100 * f['loss']:g} %" if "loss" in f else "", f"latency {f['latency_s']:g} s"
                    if "latency_s" in f else "", f"jitter {f['jitter_s']:g} s" if "jitter_s" in f else "",
                    f"duplicates {100 * f['duplicate']:g} %" if "duplicate" in f else ""]
            said += [f"outage {mm_ss(a)}-{mm_ss(b)}" for a, b in f.get("outages_s", [])]
            parts.append("link faults: " + ", ".join(x for x in said if x))
        parts += [f"aPad {a['apad']} made to fail at {mm_ss(a['at_s'])}" for a in h.get("failed_apads", [])]
        parts += [f"aPad {a['apad']} lost at {mm_ss(a['at_s'])}" for a in h.get("apads_lost", [])]
        for key, words in (("reshares", "fleet re-shared"), ("failsafe_holds", "failsafe hold"),
                           ("link_losses", "link loss"), ("gotos_resumed", "Go To resumed after a hold"),
                           ("gave_up", "step given up at its bound"),
                           ("strategy_failures", "planning step the strategy failed (cautious planned it)")):
            if h.get(key):
                parts.append(f"{words} x{h[key]}")
        if r.acoustic:
            parts.append(acoustic_words(r.acoustic))
        if parts:
            lines.append(f"{r.scenario} {r.strategy} s{r.seed}: " + "; ".join(parts))
    return lines


def acoustic_words(a: dict[str, Any]) -> str:
    """An acoustic run in one clause: frame, reports heard of sent, knowledge age, estimate error, call-ups
    (and those abandoned before they went: believed empty by the aPad's slot)."""
    counts, fleet, k = a.get("counts", {}), a.get("fleet", {}), a.get("knowledge", {})
    sent, heard = fleet.get("reports_sent", 0), counts.get("reports_heard", 0)
    calls = counts.get("call_ups_acked", 0) + counts.get("call_ups_unacked", 0)
    return (f"acoustic: TDMA frame {a.get('frame_s', 0):.2f} s, {heard:,} of {sent:,} reports heard, knowledge "
            f"{k.get('age_median_s', 0):.1f} s old (median; max {k.get('age_max_s', 0):.0f} s), battery estimate "
            f"off by {100 * k.get('battery_error_mean', 0):.2f} % (max {100 * k.get('battery_error_max', 0):.2f} %), "
            f"call-ups acknowledged {counts.get('call_ups_acked', 0)} of {calls} "
            f"({counts.get('call_up_retries', 0)} retries)"
            + (f", {abandoned} abandoned unsent" if (abandoned := counts.get("call_ups_abandoned", 0)) else ""))


def apads_table(results: list[RunResult]) -> Table | None:
    """One row per aPad of every run with several: its share, travel, dockings, idle time; None if none."""
    swarm = [r for r in results if len(r.apads) > 1]
    if not swarm:
        return None
    several = len(swarm) > 1
    table = Table(title="Per aPad", box=box.SIMPLE_HEAD)
    for col in (["run"] if several else []) + ["aPad", "share", "moved m", "cost m", "docks", "cycles", "idle %",
                                               "end"]:
        table.add_column(col, justify="left" if col in ("run", "end") else "right", no_wrap=True)
    for r in swarm:
        for a in r.apads:
            travelled = a["travelled_m"]
            row = [str(a["sysid"]), str(len(a["mussels"])), "-" if travelled is None else f"{travelled:.1f}",
                   f"{a['cost_m']:.1f}", str(a["dockings"]), str(a["cycles"]), f"{100 * a['idle_share']:.1f}",
                   f"lost at {mm_ss(a['lost_at_s'])}" if "lost_at_s" in a else str(a["end_reason"])]
            table.add_row(*([f"{r.scenario} {r.strategy} s{r.seed}"] if several else []), *row)
    return table


def time_table(results: list[RunResult]) -> Table | None:
    """Where the time went, one row per run: the aMussels' mean share of the mission active, docked
    and depleted, the first depletion, and the aPads' shares moving and holding (result.json has
    every state, docking and each aPad); None if no run says."""
    runs = [r for r in results if r.mussels and r.mussels[0].state_s]
    if not runs:
        return None
    table = Table(title="Where the time went, % of the time run", box=box.SIMPLE_HEAD, pad_edge=False,
                  collapse_padding=True,
                  caption="aMussels: fleet mean (the rest: on the way up or down); aPad: the rest docking")
    for col in ("run", "active", "docked", "depleted", "1st depl.", "aPad moving", "holding"):
        table.add_column(col, justify="left" if col == "run" else "right", no_wrap=True)
    for r in runs:
        counted = sum(sum(m.state_s.values()) for m in r.mussels)  # the time run (short of the duration: ended early)

        def pct(state: str, r: RunResult = r, counted: float = counted) -> str:
            return f"{100 * sum(m.state_s.get(state, 0.0) for m in r.mussels) / counted:.1f}" if counted else "-"

        firsts = [m.first_depleted_s for m in r.mussels if m.first_depleted_s is not None]
        apad = [f"{100 * np.mean([a.get(k, 0.0) for a in r.apads]):.1f}" if r.apads else "-"
                for k in ("travelling_share", "holding_share")]
        table.add_row(f"{r.scenario} {r.strategy} s{r.seed}", pct("active"), pct("docked"), pct("depleted"),
                      f"{min(firsts) / 60:.1f} min" if firsts else "never", *apad)
    return table


def results_table(results: list[RunResult], title: str = "Results") -> Table:
    """One row per run; where the paper ran the same thing, its figures follow in a dim row."""
    with_paper = any((r.scenario, r.strategy) in PAPER_TABLE_II for r in results)
    table = Table(title=title, caption="paper: the paper's Table II (40 min, theta 30)" if with_paper else None,
                  box=box.SIMPLE_HEAD)
    for col in ("run", "avg %", "max %", "min %", "cost m", "active", "cycles"):
        table.add_column(col, justify="left" if col == "run" else "right", no_wrap=True)
    for r in results:
        table.add_row(
            f"{r.scenario} {r.strategy} s{r.seed}",
            f"{r.uptime['avg']:.2f}", f"{r.uptime['max']:.2f}", f"{r.uptime['min']:.2f}",
            f"{r.cost_m:.1f}", f"{r.active_avg:.2f}", str(r.cycles),
        )
        paper = PAPER_TABLE_II.get((r.scenario, r.strategy))
        if paper is not None:
            avg, mx, mn, cost, active = paper
            table.add_row("  paper", f"{avg:.2f}", f"{mx:.2f}", f"{mn:.2f}", f"{cost:.1f}", f"{active:.2f}", "",
                          style="dim")
    return table


@dataclass(frozen=True)
class SeedStats:
    """Mean and spread over seeds of one (scenario, strategy)."""

    scenario: str
    strategy: str
    n: int
    mean: dict[str, float]
    std: dict[str, float]


def _columns(r: RunResult) -> dict[str, float]:
    return {"avg": r.uptime["avg"], "max": r.uptime["max"], "min": r.uptime["min"],
            "cost_m": r.cost_m, "active": r.active_avg}


def seed_stats(results: list[RunResult]) -> list[SeedStats]:
    groups: dict[tuple[str, str], list[RunResult]] = {}
    for r in results:
        groups.setdefault((r.scenario, r.strategy), []).append(r)
    out = []
    for (scenario, strategy), runs in groups.items():
        cols = [_columns(r) for r in runs]
        keys = cols[0].keys()
        out.append(SeedStats(
            scenario, strategy, len(runs),
            {k: float(np.mean([c[k] for c in cols])) for k in keys},
            {k: float(np.std([c[k] for c in cols], ddof=1)) if len(cols) > 1 else 0.0 for k in keys},
        ))
    return out


def seed_stats_table(stats: list[SeedStats], title: str) -> Table:
    table = Table(title=title, caption="mean±standard deviation over seeds", box=box.SIMPLE_HEAD, pad_edge=False)
    for col in ("scenario", "strategy", "n", "avg %", "max %", "min %", "cost m", "active"):
        table.add_column(col, justify="left" if col in ("scenario", "strategy") else "right", no_wrap=True)
    for s in stats:
        table.add_row(
            s.scenario, s.strategy, str(s.n),
            *(f"{s.mean[k]:.1f}±{s.std[k]:.1f}" for k in ("avg", "max", "min")),
            f"{s.mean['cost_m']:.0f}±{s.std['cost_m']:.0f}", f"{s.mean['active']:.2f}±{s.std['active']:.1f}",
        )
    return table


def fraction_of_seeds(results: list[RunResult], scenario: str, claim: Callable[[RunResult, RunResult], bool],
                      a: str, b: str) -> tuple[int, int]:
    """(seeds where `claim(run_a, run_b)` holds, seeds with both runs) for one scenario."""
    by = {(r.strategy, r.seed): r for r in results if r.scenario == scenario}
    seeds = sorted({seed for strategy, seed in by if strategy == a and (b, seed) in by})
    return sum(claim(by[(a, s)], by[(b, s)]) for s in seeds), len(seeds)


# The robust shape of Table II, and the one comparison the paper's single run cannot settle.
SHAPE_CLAIMS: tuple[tuple[str, str, str, Callable[[RunResult, RunResult], bool]], ...] = (
    ("cautious beats no charging (avg uptime)", "cautious", "none", lambda a, b: a.uptime["avg"] > b.uptime["avg"]),
    ("cautious lifts the minimum above greedy", "cautious", "greedy", lambda a, b: a.uptime["min"] > b.uptime["min"]),
    ("greedy moves less than cautious", "greedy", "cautious", lambda a, b: a.cost_m < b.cost_m),
    ("greedy beats no charging (avg uptime)", "greedy", "none", lambda a, b: a.uptime["avg"] > b.uptime["avg"]),
)


def shape_table(results: list[RunResult]) -> Table:
    """Per scenario, in how many seeds each Table II comparison holds."""
    scenarios = sorted({r.scenario for r in results})
    table = Table(title="Shape of Table II, seed by seed", box=box.SIMPLE_HEAD)
    table.add_column("comparison")
    for scenario in scenarios:
        table.add_column(scenario, justify="right")
    for text, a, b, claim in SHAPE_CLAIMS:
        cells = []
        for scenario in scenarios:
            held, n = fraction_of_seeds(results, scenario, claim, a, b)
            cells.append(f"{held}/{n} ({held / n:.0%})" if n else "-")
        table.add_row(text, *cells)
    return table
