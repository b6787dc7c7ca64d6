"""Sensitivity indices of a `[sensitivity]` sweep: SALib's analysis of its missions, as a table and a figure.

    vil sweep report DIR                          # a sensitivity sweep's report is this analysis
    python -m gcs.sweep.sensitivity DIR           # the same, printed

Each point of the design's sample (`gcs.sweep.sensitivity_design`) is found among the finished missions by its
field values (a point sampled twice is one mission); its response is the mean over the seeds (and the output
is analysed per scenario and strategy). Sobol: first-order and total indices (S1, ST) with their 95 %
confidence intervals (SALib's bootstrap); Morris: mu* (the mean absolute elementary effect) with its interval,
and sigma. A sweep with points still missing is refused in one line: the indices need every point.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from rich import box
from rich.console import Console
from rich.table import Table

from gcs.sweep import store
from gcs.sweep.sensitivity_design import Design, Method

DAY_S = 86400.0
RESAMPLES = 1000  # SALib's bootstrap resamples for the confidence intervals
CONF_LEVEL = 0.95
CSV, FIGURE = "sensitivity.csv", "sensitivity.png"


class AnalysisError(ValueError):
    """One line for the user: the folder and what is missing."""


def output_values(result: dict[str, Any]) -> dict[str, float]:
    """Every output a study can explain (`sensitivity_design.OUTPUTS`), from one mission's result.json."""
    mussels = result.get("mussels") or []
    days = result.get("days") or []
    mission_days = max(float(result.get("duration_s", 0.0)) / DAY_S, 1e-9)
    apads = result.get("apads") or []
    taken = sum(m.get("samples_taken", 0) for m in mussels)
    scheduled = sum(m.get("samples_scheduled", 0) for m in mussels)
    alive = days[-1]["alive"] if days else sum(1 for m in mussels if not m.get("state_s", {}).get("depleted"))
    drawn = [a["drawn_wh"] for a in apads if a.get("drawn_wh") is not None]
    return {
        "uptime_min": float(result["uptime"]["min"]),
        "uptime_avg": float(result["uptime"]["avg"]),
        "alive_at_end": float(alive),
        "apad_wh_per_day": float(np.mean(drawn)) / mission_days if drawn else math.nan,
        "samples_taken_pct": 100.0 * taken / scheduled if scheduled else math.nan,
        "dockings_per_day": sum(len(m.get("dockings", [])) for m in mussels) / mission_days,
    }


def responses(design: Design, points: list[dict[str, Any]], records: list[dict[str, Any]]
              ) -> dict[tuple[str, str], tuple[NDArray[np.float64], dict[str, NDArray[np.float64]]]]:
    """Per (scenario, strategy): the sample as run `(points, D)` and each output's mean over the seeds at each
    point; AnalysisError naming how many points have no finished mission."""
    groups: dict[tuple[str, str], dict[tuple[Any, ...], list[dict[str, float]]]] = {}
    for record in records:
        key = tuple(record["values"].get(name) for name in design.names)
        outputs = output_values(record["result"])
        groups.setdefault((record["scenario"], record["strategy"]), {}).setdefault(key, []).append(outputs)
    x = np.array([[p[name] for name in design.names] for p in points], np.float64)
    out = {}
    for group, found in sorted(groups.items()):
        keys = [tuple(p[name] for name in design.names) for p in points]
        missing = sum(1 for k in keys if k not in found)
        if missing:
            raise AnalysisError(f"{group[0]} {group[1]}: {missing} of {len(points)} points have no finished "
                                "mission yet (run the sweep again to finish them)")
        y = {name: np.array([np.mean([o[name] for o in found[k]]) for k in keys], np.float64)
             for name in design.outputs}
        out[group] = (x, y)
    return out


def indices(design: Design, x: NDArray[np.float64], y: NDArray[np.float64]) -> pd.DataFrame:
    """One output's indices, a row per field: SALib's, with 95 % intervals. A constant output (nothing changed
    it) has no indices to give: NaN, not SALib's division by zero."""
    problem = design.problem()
    if not np.all(np.isfinite(y)) or np.ptp(y) == 0.0:
        nan = [math.nan] * len(design.names)
        cols = ("S1", "S1_conf", "ST", "ST_conf") if design.method is Method.SOBOL else ("mu_star", "mu_star_conf",
                                                                                          "sigma")
        return pd.DataFrame({"field": design.names, **{c: nan for c in cols}})
    if design.method is Method.SOBOL:
        from SALib.analyze import sobol

        s = sobol.analyze(problem, y, calc_second_order=design.second_order, num_resamples=RESAMPLES,
                          conf_level=CONF_LEVEL, seed=design.seed)
        return pd.DataFrame({"field": design.names, "S1": s["S1"], "S1_conf": s["S1_conf"], "ST": s["ST"],
                             "ST_conf": s["ST_conf"]})
    from SALib.analyze import morris

    m = morris.analyze(problem, x, y, num_resamples=RESAMPLES, conf_level=CONF_LEVEL, num_levels=design.levels,
                       seed=design.seed)
    return pd.DataFrame({"field": design.names, "mu_star": m["mu_star"], "mu_star_conf": m["mu_star_conf"],
                         "sigma": m["sigma"]})


def analyse(folder: Path) -> tuple[Design, pd.DataFrame]:
    """Every output's indices for each scenario and strategy of the sweep in `folder`."""
    meta = store.read_sweep(folder)
    if "sensitivity" not in meta:
        raise AnalysisError(f"{folder}: not a sensitivity sweep (its spec has no [sensitivity] table)")
    design = Design.from_json(meta["sensitivity"])
    points = meta.get("points") or design.points()
    try:
        records = store.read_cells(folder)
    except FileNotFoundError as exc:
        raise AnalysisError(str(exc)) from None
    frames = []
    for (scenario, strategy), (x, ys) in responses(design, points, records).items():
        for output, y in ys.items():
            table = indices(design, x, y)
            table.insert(0, "output", output)
            table.insert(0, "strategy", strategy)
            table.insert(0, "scenario", scenario)
            frames.append(table)
    return design, pd.concat(frames, ignore_index=True)


def rich_table(design: Design, table: pd.DataFrame, title: str) -> Table:
    out = Table(title=title, box=box.SIMPLE_HEAD, pad_edge=False,
                caption="± the 95 % confidence interval (SALib's bootstrap)")
    sobol = design.method is Method.SOBOL
    heads = ("S1 first order", "ST total") if sobol else ("mu*", "sigma")
    for name in ("scenario", "strategy", "output", "field", *heads):
        out.add_column(name, justify="right" if name in heads else "left", no_wrap=True)
    for _, r in table.iterrows():
        if sobol:
            cells = (_pm(r["S1"], r["S1_conf"]), _pm(r["ST"], r["ST_conf"]))
        else:
            cells = (_pm(r["mu_star"], r["mu_star_conf"]), _num(r["sigma"]))
        out.add_row(str(r["scenario"]), str(r["strategy"]), str(r["output"]), str(r["field"]), *cells)
    return out


def _pm(value: float, half: float) -> str:
    return "-" if math.isnan(value) else f"{value:.3f} ± {half:.3f}"


def _num(value: float) -> str:
    return "-" if math.isnan(value) else f"{value:.3g}"


def figure(design: Design, table: pd.DataFrame, path: Path) -> None:
    """A panel per output (and scenario/strategy): each field's indices as bars with their intervals."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = list(table.groupby(["scenario", "strategy", "output"], sort=False))
    fig, axes = plt.subplots(len(panels), 1, figsize=(8, 2.2 + 0.35 * len(design.names) * len(panels)),
                             squeeze=False)
    at = np.arange(len(design.names))
    for ax, ((scenario, strategy, output), rows) in zip(axes[:, 0], panels, strict=True):
        if design.method is Method.SOBOL:
            ax.barh(at - 0.2, rows["S1"], 0.4, xerr=rows["S1_conf"], label="S1 (first order)", capsize=2)
            ax.barh(at + 0.2, rows["ST"], 0.4, xerr=rows["ST_conf"], label="ST (total)", capsize=2)
            ax.set_xlabel("Sobol index")
        else:
            ax.barh(at, rows["mu_star"], 0.6, xerr=rows["mu_star_conf"], label="mu*", capsize=2)
            ax.set_xlabel("mu* (mean |elementary effect|)")
        ax.set_yticks(at, list(rows["field"]))
        ax.invert_yaxis()
        ax.set_title(f"{output}: {scenario}, {strategy}", fontsize=10)
        ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_report(folder: Path, console: Console | None = None) -> list[Path]:
    """DIR/report/sensitivity.csv and .png; the table printed to `console` if given."""
    design, table = analyse(folder)
    out = folder / "report"
    out.mkdir(parents=True, exist_ok=True)
    written = [out / CSV, out / FIGURE]
    table.to_csv(written[0], index=False)
    figure(design, table, written[1])
    if console is not None:
        n = len(store.read_sweep(folder).get("points") or design.points())
        console.print(rich_table(design, table, f"{design.method} indices over {len(design.names)} fields, "
                                                f"{n} points (n = {design.n})"))
    return written


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m gcs.sweep.sensitivity", description=__doc__.split("\n\n")[0])
    parser.add_argument("folder", type=Path, help="the sweep folder (vil sweep SPEC --out DIR)")
    args = parser.parse_args(argv)
    try:
        written = write_report(args.folder, Console())
    except (AnalysisError, store.StoreError) as exc:
        print(f"sensitivity: {exc}", file=sys.stderr)
        return 2
    print("written: " + ", ".join(str(p) for p in written))
    return 0


if __name__ == "__main__":
    sys.exit(main())
