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
from gcs.sweep.outputs import output_values
from gcs.sweep.sensitivity_design import Design, Method

RESAMPLES = 1000  # SALib's bootstrap resamples for the confidence intervals
CONF_LEVEL = 0.95
CSV, PAIRS_CSV, FIGURE = "sensitivity.csv", "sensitivity-pairs.csv", "sensitivity.png"
PAIRS_SHOWN = 3  # the strongest pairs printed per output


class AnalysisError(ValueError):
    """One line for the user: the folder and what is missing."""


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


PAIR_COLUMNS = ["field_a", "field_b", "S2", "S2_conf"]


def indices(design: Design, x: NDArray[np.float64], y: NDArray[np.float64]) -> tuple[pd.DataFrame, pd.DataFrame]:
    """One output's indices with 95 % intervals, SALib's: a row per field (S1 and ST, or mu* and sigma), and with
    second order a row per pair of fields (S2: what the two explain together beyond each alone). A constant
    output (nothing changed it) has no indices to give: NaN, not SALib's division by zero."""
    problem, names = design.problem(), design.names
    pairs = pd.DataFrame(columns=PAIR_COLUMNS)
    if not np.all(np.isfinite(y)) or np.ptp(y) == 0.0:
        nan = [math.nan] * len(names)
        cols = ("S1", "S1_conf", "ST", "ST_conf") if design.method is Method.SOBOL else ("mu_star", "mu_star_conf",
                                                                                          "sigma")
        if design.method is Method.SOBOL and design.second_order:
            pairs = pd.DataFrame([(a, b, math.nan, math.nan) for i, a in enumerate(names) for b in names[i + 1:]],
                                 columns=PAIR_COLUMNS)
        return pd.DataFrame({"field": names, **{c: nan for c in cols}}), pairs
    if design.method is Method.SOBOL:
        from SALib.analyze import sobol

        s = sobol.analyze(problem, y, calc_second_order=design.second_order, num_resamples=RESAMPLES,
                          conf_level=CONF_LEVEL, seed=design.seed)
        if design.second_order:
            pairs = pd.DataFrame([(names[i], names[j], s["S2"][i, j], s["S2_conf"][i, j])
                                  for i in range(len(names)) for j in range(i + 1, len(names))], columns=PAIR_COLUMNS)
        return pd.DataFrame({"field": names, "S1": s["S1"], "S1_conf": s["S1_conf"], "ST": s["ST"],
                             "ST_conf": s["ST_conf"]}), pairs
    from SALib.analyze import morris

    m = morris.analyze(problem, x, y, num_resamples=RESAMPLES, conf_level=CONF_LEVEL, num_levels=design.levels,
                       seed=design.seed)
    return pd.DataFrame({"field": names, "mu_star": m["mu_star"], "mu_star_conf": m["mu_star_conf"],
                         "sigma": m["sigma"]}), pairs


def analyse(folder: Path) -> tuple[Design, pd.DataFrame, pd.DataFrame]:
    """Every output's indices for each scenario and strategy of the sweep in `folder`: per field, and per pair
    of fields (second order). Only the sweep's own missions: a folder may hold others' (a spec changed)."""
    meta = store.read_sweep(folder)
    if "sensitivity" not in meta:
        raise AnalysisError(f"{folder}: not a sensitivity sweep (its spec has no [sensitivity] table)")
    design = Design.from_json(meta["sensitivity"])
    points = meta.get("points") or design.points()
    try:
        records = store.read_cells(folder)
    except FileNotFoundError as exc:
        raise AnalysisError(str(exc)) from None
    if "keys" in meta:
        mine = set(meta["keys"])
        records = [r for r in records if r["key"] in mine]
    frames: list[pd.DataFrame] = []
    pair_frames: list[pd.DataFrame] = []
    for (scenario, strategy), (x, ys) in responses(design, points, records).items():
        for output, y in ys.items():
            for frame, found in zip((frames, pair_frames), indices(design, x, y), strict=True):
                found.insert(0, "output", output)
                found.insert(0, "strategy", strategy)
                found.insert(0, "scenario", scenario)
                frame.append(found)
    return design, pd.concat(frames, ignore_index=True), pd.concat(pair_frames, ignore_index=True)


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
        if rows.drop(columns=["scenario", "strategy", "output", "field"]).isna().all().all():
            ax.text(0.5, 0.5, "the same in every mission: no index", transform=ax.transAxes, ha="center")
        ax.set_yticks(at, list(rows["field"]))
        ax.invert_yaxis()
        ax.set_title(f"{output}: {scenario}, {strategy}", fontsize=10)
        ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_report(folder: Path, console: Console | None = None) -> list[Path]:
    """DIR/report/sensitivity.csv (and -pairs.csv with second order) and .png; the tables printed to `console`."""
    design, table, pairs = analyse(folder)
    out = folder / "report"
    out.mkdir(parents=True, exist_ok=True)
    written = [out / CSV, out / FIGURE]
    table.to_csv(written[0], index=False)
    figure(design, table, written[1])
    if len(pairs):
        written.append(out / PAIRS_CSV)
        pairs.to_csv(written[-1], index=False)
    if console is not None:
        n = len(store.read_sweep(folder).get("points") or design.points())
        console.print(rich_table(design, table, f"{design.method} indices over {len(design.names)} fields, "
                                                f"{n} points (n = {design.n})"))
        if len(pairs):
            console.print(pairs_table(pairs))
    return written


def pairs_table(pairs: pd.DataFrame) -> Table:
    """The strongest PAIRS_SHOWN pairs (S2) of each output."""
    out = Table(title="second order: the strongest pairs", box=box.SIMPLE_HEAD, pad_edge=False)
    for name in ("scenario", "strategy", "output", "fields", "S2"):
        out.add_column(name, justify="right" if name == "S2" else "left", no_wrap=True)
    for _, group in pairs.groupby(["scenario", "strategy", "output"], sort=False):
        for _, r in group.sort_values("S2", ascending=False, na_position="last").head(PAIRS_SHOWN).iterrows():
            out.add_row(str(r["scenario"]), str(r["strategy"]), str(r["output"]),
                        f"{r['field_a']} x {r['field_b']}", _pm(r["S2"], r["S2_conf"]))
    return out


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
