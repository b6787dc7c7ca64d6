"""`vil sweep report DIR`: what a sweep found, as tables and plots in DIR/report/.

    summary.csv, summary.md   per scenario and configuration (strategy and swept values): n, mean
                              and 95 % interval of avg / min / max uptime, cost, active count; the
                              Pareto front (avg and min uptime up, cost down)
    pareto.png                uptime against cost, every run and each configuration's mean, front marked
    uptime.png                distributions of avg and min uptime per configuration
    active.png                active aMussels over mission time: median and 10-90 % band per configuration
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from rich import box
from rich.console import Console
from rich.table import Table

from gcs.sweep import store
from gcs.sweep.stats import pareto_front, summary

REPORT = "report"
BAND = (0.10, 0.90)
UPTIMES = (("uptime.avg", "average uptime (%)"), ("uptime.min", "minimum uptime (%)"))


class ReportError(ValueError):
    """A sweep folder with nothing to report (one line)."""


def configuration(rows: pd.DataFrame, swept: list[str]) -> pd.Series:
    """What a run's configuration is called: its strategy, then its swept values."""
    label = rows["strategy"].astype(str)
    for field in swept:
        label = label + " " + field.split(".")[-1] + "=" + rows[field].astype(str)
    return label


def load(folder: Path) -> tuple[dict[str, Any], pd.DataFrame, pd.DataFrame]:
    meta = store.read_sweep(folder)
    try:
        rows = pd.read_parquet(folder / f"{store.RESULTS}.parquet")
        active = pd.read_parquet(folder / store.ACTIVE)
    except (OSError, ValueError) as exc:
        raise ReportError(f"{folder}: no results to report ({exc}); run the sweep first") from None
    if rows.empty:
        raise ReportError(f"{folder}: the results hold no runs")
    rows["config"] = configuration(rows, meta["swept"])
    if not active.empty:
        active["config"] = configuration(active, meta["swept"])
    return meta, rows, active


def platforms_of(rows: pd.DataFrame) -> str:
    """What the runs ran on, for a title: "lockstep", "event", or both (results from before issue 37: lockstep)."""
    names = sorted(set(rows["platform"])) if "platform" in rows.columns else ["lockstep"]
    return " and ".join(f"{n} platform" if k == len(names) - 1 else n for k, n in enumerate(names))


def write_report(folder: Path, console: Console | None = None) -> list[Path]:
    """Tables and plots of the sweep in `folder`; prints the table to `console` if given. A sensitivity
    sweep's are its indices (`gcs.sweep.sensitivity`): a summary per point would be thousands of rows."""
    if "sensitivity" in store.read_sweep(folder):
        from gcs.sweep.sensitivity import AnalysisError
        from gcs.sweep.sensitivity import write_report as sensitivity_report

        try:
            return sensitivity_report(folder, console)
        except AnalysisError as exc:
            raise ReportError(str(exc)) from None
    meta, rows, active = load(folder)
    out = folder / REPORT
    out.mkdir(parents=True, exist_ok=True)
    table = summary(rows, ["scenario", "config"])
    written = [out / "summary.csv", out / "summary.md"]
    table.to_csv(written[0], index=False)
    title = f"{meta['name']} ({platforms_of(rows)})"
    written[1].write_text(markdown(table, title), encoding="utf-8")
    if console is not None:
        console.print(rich_table(table, title))
    written += _plots(out, rows, active, table)
    return written


def _cell(mean: float, half: float, digits: int, sep: str = " ± ") -> str:
    if math.isnan(mean):
        return "-"
    return f"{mean:.{digits}f}" + ("" if math.isnan(half) else f"{sep}{half:.{digits}f}")


COLUMNS = (("avg %", "uptime.avg", 1), ("min %", "uptime.min", 1), ("cost m", "cost_m", 0),
           ("active", "active_avg", 2))


def _cells(r: pd.Series, sep: str = " ± ") -> list[str]:
    return [_cell(r[f"{col}.mean"], r[f"{col}.ci95"], d, sep) for _, col, d in COLUMNS]


def rich_table(table: pd.DataFrame, title: str) -> Table:
    """Narrow enough for 80 columns with the strategies' names; a longer configuration folds."""
    out = Table(title=f"{title}: means with 95 % intervals", box=box.SIMPLE_HEAD, pad_edge=False,
                caption="* on the Pareto front of its scenario (avg and min uptime up, cost down)")
    longest = max((len(str(c)) for c in table["config"]), default=6)
    for name in ("scenario", "config", "n", *(c[0] for c in COLUMNS), "*"):
        if name == "config":
            out.add_column(name, min_width=min(longest, 24), overflow="fold")
        else:
            out.add_column(name, justify="left" if name == "scenario" else "right", no_wrap=True)
    for _, r in table.iterrows():
        out.add_row(str(r["scenario"]), str(r["config"]), str(r["n"]), *_cells(r, "±"), "*" if r["front"] else "",
                    style="bold" if r["front"] else None)
    return out


def markdown(table: pd.DataFrame, title: str) -> str:
    head = ["scenario", "configuration", "n", *(c[0] for c in COLUMNS), "Pareto front"]
    lines = [f"# {title}: means with 95 % intervals", "", "| " + " | ".join(head) + " |",
             "|" + "|".join("---" if i < 2 else "---:" for i in range(len(head))) + "|"]
    for _, r in table.iterrows():
        cells = [str(r["scenario"]), str(r["config"]), str(r["n"]), *_cells(r), "yes" if r["front"] else ""]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _plots(out: Path, rows: pd.DataFrame, active: pd.DataFrame, table: pd.DataFrame) -> list[Path]:
    from matplotlib.figure import Figure  # no pyplot: no display, no global state

    scenarios = list(dict.fromkeys(rows["scenario"]))
    configs = list(dict.fromkeys(rows["config"]))
    palette = _palette(len(configs))
    colour = dict(zip(configs, palette, strict=True))
    paths = [out / "pareto.png", out / "uptime.png", out / "active.png"]

    fig = Figure(figsize=(6.5 * len(scenarios), 5.2), layout="constrained")
    for ax, scenario in zip(np.atleast_1d(fig.subplots(1, len(scenarios))), scenarios, strict=True):
        runs = rows[rows["scenario"] == scenario]
        means = table[table["scenario"] == scenario]
        for config, group in runs.groupby("config", sort=False):
            ax.scatter(group["cost_m"], group["uptime.avg"], s=10, alpha=0.3, color=colour[config])
        for _, m in means.iterrows():
            ax.errorbar(m["cost_m.mean"], m["uptime.avg.mean"], xerr=_nz(m["cost_m.ci95"]),
                        yerr=_nz(m["uptime.avg.ci95"]), fmt="o", ms=7, color=colour[m["config"]],
                        mec="black" if m["front"] else colour[m["config"]], mew=1.5, label=m["config"], capsize=2)
        # The dashed staircase: the front of this plane; a black edge: the front of avg, min uptime and cost.
        plane = pareto_front(np.column_stack([means["uptime.avg.mean"], -means["cost_m.mean"]]))
        front = means[plane].sort_values("cost_m.mean")
        ax.step(front["cost_m.mean"], front["uptime.avg.mean"], where="post", color="black", lw=1, ls="--",
                label="front of avg uptime and cost")
        ax.plot([], [], "o", mfc="white", mec="black", mew=1.5, label="black edge: front of avg, min uptime, cost")
        ax.set(title=scenario, xlabel="movement cost per run (m)", ylabel="average uptime (%)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    fig.savefig(paths[0], dpi=110)

    fig = Figure(figsize=(max(6.0, 0.7 * len(configs) * len(scenarios) + 2), 7.5), layout="constrained")
    axes = np.asarray(fig.subplots(2, len(scenarios), squeeze=False))
    for j, scenario in enumerate(scenarios):
        runs = rows[rows["scenario"] == scenario]
        present = [c for c in configs if (runs["config"] == c).any()]
        for i, (figure, name) in enumerate(UPTIMES):
            ax = axes[i, j]
            parts = ax.boxplot([runs.loc[runs["config"] == c, figure].dropna() for c in present],
                               patch_artist=True, widths=0.6)
            for patch, c in zip(parts["boxes"], present, strict=True):
                patch.set(facecolor=colour[c], alpha=0.6)
            ax.set_xticks(range(1, len(present) + 1), present, rotation=30, ha="right", fontsize=8)
            ax.set(title=f"{scenario}: {name}", ylabel=name)
            ax.grid(axis="y", alpha=0.3)
    fig.savefig(paths[1], dpi=110)

    fig = Figure(figsize=(6.5 * len(scenarios), 4.8), layout="constrained")
    for ax, scenario in zip(np.atleast_1d(fig.subplots(1, len(scenarios))), scenarios, strict=True):
        series = active[active["scenario"] == scenario] if not active.empty else active
        for config, group in series.groupby("config", sort=False) if not series.empty else []:
            by_t = group.groupby("t_s")["active"]
            q = by_t.quantile(list(BAND)).unstack()
            ax.fill_between(q.index / 60, q[BAND[0]], q[BAND[1]], color=colour[config], alpha=0.15, lw=0)
            ax.plot(by_t.median().index / 60, by_t.median().to_numpy(), color=colour[config], lw=1.2, label=config)
        ax.set(title=f"{scenario}: active aMussels (median, {BAND[0]:.0%}-{BAND[1]:.0%} of runs)",
               xlabel="mission time (min)", ylabel="active aMussels")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="lower left")
    fig.savefig(paths[2], dpi=110)
    return paths


def _nz(half: float) -> float:
    return 0.0 if math.isnan(half) else half


def _palette(n: int) -> list[Any]:
    from matplotlib import colormaps

    cmap = colormaps["tab10" if n <= 10 else "tab20"]
    return [cmap(i % cmap.N) for i in range(n)]
