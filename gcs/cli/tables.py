"""What `vil run` prints: the runs' figures as rich tables beside the paper's (`gcs.results` holds the data),
the per-day table, what happened besides the figures, and who ended where they should not."""

from __future__ import annotations

import os
import sys
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from rich import box
from rich.console import Console
from rich.table import Table

from gcs.results.days import MAX_ROWS, groups
from gcs.results.run_result import SHAPE_CLAIMS, RunResult, SeedStats, fraction_of_seeds, paper_figures
from missiontime.durations import hms

PIPED_WIDTH = 1000  # written to a file or a pipe, output is as wide as it needs, never cut at 80 columns



class OutputConsole(Console):
    """rich's console, but a reader that stops reading (`vil run | head -3`) is not an error: it has
    what it wanted. What is printed after goes nowhere, and the command ends with its own status
    (rich's default exits 1 on the spot, with no word)."""

    def on_broken_pipe(self) -> None:
        self.quiet = True
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # Python's own flush at exit, too


def output_console() -> Console:
    """Where the tables go: the terminal's width on a terminal (or $COLUMNS if set); a file or a
    pipe gets every column and every line whole (rich would cut them at 80 columns)."""
    piped = not sys.stdout.isatty() and "COLUMNS" not in os.environ
    return OutputConsole(width=PIPED_WIDTH) if piped else OutputConsole()



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
            said += [f"outage {hms(a)}-{hms(b)}" for a, b in f.get("outages_s", [])]
            parts.append("link faults: " + ", ".join(x for x in said if x))
        parts += [f"aPad {a['apad']} made to fail at {hms(a['at_s'])}" for a in h.get("failed_apads", [])]
        parts += [f"aPad {a['apad']} lost at {hms(a['at_s'])}" for a in h.get("apads_lost", [])]
        for key, words in (("reshares", "fleet re-shared"), ("failsafe_holds", "failsafe hold"),
                           ("link_losses", "link loss"), ("gotos_resumed", "Go To resumed after a hold"),
                           ("gave_up", "step given up at its bound"),
                           ("strategy_failures", "planning step the strategy failed (cautious planned it)")):
            if h.get(key):
                parts.append(f"{words} x{h[key]}")
        if h.get("failed_dockings"):  # by what became of the aMussel
            by = h["failed_dockings"]
            parts.append(f"docking failed x{sum(by.values())} (" + ", ".join(f"{k} {n}" for k, n in by.items()) + ")")
        parts += home_charge_words(r) + depletion_words(r)
        if r.acoustic:
            parts.append(acoustic_words(r.acoustic))
        if parts:
            lines.append(f"{r.scenario} {r.strategy} s{r.seed}: " + "; ".join(parts))
    return lines



def home_charge_words(r: RunResult) -> list[str]:
    """Each aPad that went home to charge: how often, and its hours at the charger (its `home charge` phase)."""
    return [f"aPad {a['sysid']} charged at home x{a['home_charges']} "
            f"({hms(a.get('phase_s', {}).get('home charge', 0.0))} at the charger)"
            for a in r.apads if a.get("home_charges")]


def depletion_words(r: RunResult) -> list[str]:
    """How many aMussels ran flat, and when the first and the last did (a result, not a fault: exit 0)."""
    flat = sorted(m.first_depleted_s for m in r.mussels if m.first_depleted_s is not None)
    if not flat:
        return []
    who = "every aMussel" if len(flat) == len(r.mussels) else f"{len(flat)} of {len(r.mussels)} aMussels"
    when = f"at {hms(flat[0])}" if len(flat) == 1 else f"the first at {hms(flat[0])}, the last at {hms(flat[-1])}"
    return [f"{who} ran flat ({when})"]


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
                   f"lost at {hms(a['lost_at_s'])}" if "lost_at_s" in a else str(a["end_reason"])]
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
    """One row per run; where the paper ran the same thing (40 min, theta 30), its figures follow in a dim row."""
    papers = [paper_figures(r.scenario, r.strategy, r.duration_s, r.theta) for r in results]
    with_paper = any(p is not None for p in papers)
    table = Table(title=title, caption="paper: the paper's Table II (40 min, theta 30)" if with_paper else None,
                  box=box.SIMPLE_HEAD)
    for col in ("run", "avg %", "max %", "min %", "cost m", "active", "cycles"):
        table.add_column(col, justify="left" if col == "run" else "right", no_wrap=True)
    for r, paper in zip(results, papers, strict=True):
        table.add_row(
            f"{r.scenario} {r.strategy} s{r.seed}",
            f"{r.uptime['avg']:.2f}", f"{r.uptime['max']:.2f}", f"{r.uptime['min']:.2f}",
            f"{r.cost_m:.1f}", f"{r.active_avg:.2f}", str(r.cycles),
        )
        if paper is not None:
            avg, mx, mn, cost, active = paper
            table.add_row("  paper", f"{avg:.2f}", f"{mx:.2f}", f"{mn:.2f}", f"{cost:.1f}", f"{active:.2f}", "",
                          style="dim")
    return table



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



def days_table(runs: Sequence[tuple[str, Sequence[Mapping[str, Any]]]], max_rows: int = MAX_ROWS) -> Table | None:
    """Per simulated day of each run (label, its day rows) with two days or more; None if none has."""
    long_runs = [(label, rows) for label, rows in runs if len(rows) > 1]
    if not long_runs:
        return None
    table = Table(title="Per sim. day (the aMussels' day: 86,400 s / theta of mission time)", box=box.SIMPLE_HEAD,
                  pad_edge=False, collapse_padding=True,
                  caption="uptime: fleet mean; alive: not depleted at the (last) day's end; "
                          "charged, Wh passed: per aPad and day")
    for col in ("run", "sim. day", "mission time", "uptime %", "alive", "depl.", "charged", "Wh passed"):
        table.add_column(col, justify="left" if col in ("run", "mission time") else "right", no_wrap=True)
    for label, rows in long_runs:
        for span in groups(len(rows), max_rows):
            chunk = [rows[d] for d in span]
            apads = max(len(chunk[0]["charges"]), 1)
            charged = sum(sum(r["charges"].values()) for r in chunk) / (apads * len(chunk))
            passed = [sum(r["passed_wh"].values()) for r in chunk if r["passed_wh"]]
            days = f"{span[0] + 1}" if len(span) == 1 else f"{span[0] + 1}-{span[-1] + 1}"
            table.add_row(label, days, f"{_hm(chunk[0]['from_s'])}-{_hm(chunk[-1]['to_s'])}",
                          f"{np.mean([r['uptime_pct'] for r in chunk]):.1f}", str(chunk[-1]["alive"]),
                          str(sum(r["depleted"] for r in chunk)), f"{charged:.1f}",
                          f"{np.mean(passed) / apads:.1f}" if passed else "-")
            label = ""
    return table



def _hm(seconds: float) -> str:
    """Mission time as h:mm."""
    minutes = round(seconds / 60)
    return f"{minutes // 60}:{minutes % 60:02d}"
