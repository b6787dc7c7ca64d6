"""Several runs side by side (`vil report A B ... -o OUT`): a row per run, and figures that overlay
them: active aMussels and movement cost over mission time, and each run's spread of uptime.
Each run keeps its own full report in a folder beside the comparison page, linked from it."""

from __future__ import annotations

import html
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from gcs.report.page import INDEX_HEADERS, Figure, figures_html, indices_rows, page, table
from gcs.report.run_data import RunData
from gcs.report.style import BLACK, figure, grid, save, series_style


def labels(runs: Sequence[RunData]) -> list[str]:
    """Each run's name in the legends: its title, with its folder where two titles are the same."""
    titles = [r.title for r in runs]
    return [f"{r.title} ({r.name})" if titles.count(r.title) > 1 else r.title for r in runs]


def active_png(runs: Sequence[RunData], names: Sequence[str], path: Path) -> Path:
    fig, ax = figure(9.0, 4.2)
    grid(ax)
    for k, (run, name) in enumerate(zip(runs, names, strict=True)):
        s = series_style(k)
        mean = float(run.active.mean()) if run.active.size else 0.0
        ax.step(run.t_s / 60.0, run.active, where="post", color=s.colour, ls=s.line, lw=1.4,
                label=f"{name}: mean {mean:.2f}")
    ax.set(xlabel="mission time [min]", ylabel="active aMussels [count]", ylim=(0, None),
           title="Active aMussels over time")
    ax.yaxis.get_major_locator().set_params(integer=True)
    ax.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.0, 0.5))
    return save(fig, path)


def cost_png(runs: Sequence[RunData], names: Sequence[str], path: Path) -> Path:
    fig, ax = figure(9.0, 4.2)
    grid(ax)
    for k, (run, name) in enumerate(zip(runs, names, strict=True)):
        s = series_style(k)
        ax.plot(run.t_s / 60.0, run.cost_m, color=s.colour, ls=s.line, lw=1.6,
                label=f"{name}: {run.indices.cost_m:.1f} m")
    ax.set(xlabel="mission time [min]", ylabel="movement cost so far [m]", ylim=(0, None),
           title="Movement cost over time (every aPad, summed)")
    ax.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.0, 0.5))
    return save(fig, path)


def uptime_png(runs: Sequence[RunData], names: Sequence[str], path: Path) -> Path:
    """A box of each run's per-aMussel uptimes, every aMussel a point on it, the average a diamond."""
    fig, ax = figure(max(6.0, 1.6 * len(runs) + 3.0), 4.4)
    grid(ax)
    values = [np.array([m.uptime_pct for m in run.mussels]) for run in runs]
    x = np.arange(1, len(runs) + 1)
    ax.boxplot(values, positions=x, widths=0.5, showfliers=False, medianprops={"color": BLACK})
    rng = np.random.default_rng(0)  # the same spread of points on every report
    for k, v in enumerate(values):
        s = series_style(k)
        ax.plot(x[k] + rng.uniform(-0.15, 0.15, v.size), v, s.marker, color=s.colour, mec=BLACK, mew=0.4,
                ms=5, alpha=0.9)
        if v.size:
            ax.plot(x[k], v.mean(), "D", color="white", mec=BLACK, ms=8, zorder=4)
    ax.set_xticks(x, [n.replace(" (", "\n(") for n in names], fontsize=8)
    ax.set(ylabel="uptime per aMussel [%]", ylim=(0, 105), title="Uptime per aMussel (eq. 3); diamond: average")
    return save(fig, path)


FIGURES = (
    ("compare_active.png", active_png, "Active aMussels over time",
     "One line per run: how many aMussels were measuring at each mission second; the legend gives each "
     "run's mean (the paper's active index)."),
    ("compare_cost.png", cost_png, "Movement cost over time",
     "One line per run: the metres the aPads had been sent so far (aPad to each Go To target, summed over "
     "aPads); the legend gives each run's total."),
    ("compare_uptime.png", uptime_png, "Uptime per aMussel",
     "One box per run: the middle half of its aMussels' uptimes, whiskers to the extremes; each point is "
     "one aMussel, the diamond the average (the paper's avg uptime)."),
)


def write_comparison(runs: Sequence[RunData], folders: Sequence[str], out: Path) -> list[Path]:
    """The comparison figures and index.html in `out`; `folders`: each run's report, relative to `out`."""
    names = labels(runs)
    written = [draw(runs, names, out / file) for file, draw, _, _ in FIGURES]
    rows: list[list[object]] = []
    for run, name in zip(runs, names, strict=True):
        r = run.result
        row = indices_rows(run, name)[0]
        rows.append([*row, r.get("scenario", "-"), r.get("strategy", "-"), r.get("seed", "-"), len(run.tracks),
                     run.ids.size, f"{run.end_s / 60:.1f}", sum(m.never_collected for m in run.mussels),
                     sum(m.depleted for m in run.mussels)])
    headers = (*INDEX_HEADERS, "scenario", "strategy", "seed", "aPads", "aMussels", "minutes", "never collected",
               "depleted")
    links = "".join(f'<li><a href="{html.escape(f)}/index.html">{html.escape(n)}</a> — {html.escape(str(r.folder))}'
                    f"</li>" for r, n, f in zip(runs, names, folders, strict=True))
    body = "\n".join([
        f"<h1>Comparison of {len(runs)} runs</h1>",
        '<h2 id="summary">Summary</h2>',
        table(headers, rows, "A row per run, the paper's Table II indices first; never collected / depleted: "
                             "how many aMussels."),
        "<h2>Each run's own report</h2>", f"<ul>{links}</ul>",
        '<h2 id="figures">Figures</h2>',
        figures_html([Figure(file, title, caption) for file, _, title, caption in FIGURES]),
    ])
    index = out / "index.html"
    index.write_text(page(f"vil report: {len(runs)} runs compared", body), encoding="utf-8")
    return [*written, index]
